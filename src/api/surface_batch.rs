//! `SurfaceBatch`: a material at N hits, every method of [`Surface`] over
//! columns of inputs, one native call per method per batch
//! ([`Function::call_batch`]). The same choices as a surface (a prepared
//! hit's record, a combined entry, or the methods one by one; the calls a
//! material's facts make needless), so each point's result is the bits
//! [`Surface`] gives there.

use super::batch::{Column, Layout, ShadingBatch};
use super::material::Material;
use super::{Backend, Error, Function};
use crate::check::Method;
use crate::ir::lower::{DeltaLobesLayout, EvalPdfLayout, HitMethod, SampleLayout};

#[cfg(doc)]
use super::Surface;

/// Colors of a batch, point by point: `lanes` floats per point.
#[derive(Debug, Clone, PartialEq)]
pub struct ColorBatch {
    pub lanes: usize,
    /// `len × lanes`, row-major (a numpy array of shape `(n, lanes)`).
    pub values: Vec<f32>,
}

impl ColorBatch {
    fn zeros(points: usize, lanes: usize) -> ColorBatch {
        ColorBatch { lanes, values: vec![0.0; points * lanes] }
    }

    /// The lanes of point `i`.
    ///
    /// # Panics
    /// When `i` is not below [`ColorBatch::len`].
    pub fn get(&self, i: usize) -> &[f32] {
        &self.values[i * self.lanes..(i + 1) * self.lanes]
    }

    pub fn len(&self) -> usize {
        self.values.len().checked_div(self.lanes).unwrap_or(0)
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
}

/// [`Surface::sample`] at every point of a batch.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleBatch {
    pub wi: Vec<[f32; 3]>,
    pub weight: ColorBatch,
    pub pdf: Vec<f32>,
    pub delta: Vec<bool>,
}

/// [`Surface::eval_pdf`] at every point of a batch.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalPdfBatch {
    pub value: ColorBatch,
    pub pdf: Vec<f32>,
}

/// [`Surface::delta_lobes`] at every point of a batch: a direction of
/// zeros (with a zero weight) where a point has no such lobe.
#[derive(Debug, Clone, PartialEq)]
pub struct DeltaLobesBatch {
    pub reflect_dir: Vec<[f32; 3]>,
    pub reflect_weight: ColorBatch,
    pub refract_dir: Vec<[f32; 3]>,
    pub refract_weight: ColorBatch,
}

/// A material at every point of a batch: see [`Material::at_batch`].
pub struct SurfaceBatch<'a> {
    material: &'a Material,
    points: &'a ShadingBatch<'a>,
    wo: [Column<'a>; 3],
    eta: Vec<Column<'a>>,
    /// The prepared hits' records, point by point, once a call needed them.
    records: Option<Vec<u32>>,
}

/// Batches call compiled code.
const JIT: Backend = Backend::Jit;

impl Material {
    /// The material at every point of `points`, seen from `wo` (one unit
    /// vector per point, toward the viewer) with the relative index `eta`
    /// (one column per lane of the color model): [`Material::at`] for a
    /// batch.
    ///
    /// ```
    /// use tsl::{Column, Compiler, ShadingBatch};
    /// let program = Compiler::new().source("m.tsl", "material m = lambert(kd: gray(0.5));").compile()?;
    /// let m = program.material("m")?;
    /// let n = [[0.0f32, 0.0, 1.0]; 4];
    /// let mut points = ShadingBatch::new(4);
    /// points.set_vectors("N", &n)?.set_vectors("Ng", &n)?;
    /// let wo = Column::vectors(&n);
    /// let eta = Column::uniforms(&[1.0, 1.0, 1.0]);
    /// let mut surfaces = m.at_batch(&points, wo, &eta)?;
    /// let u = [0.1f32, 0.4, 0.6, 0.9];
    /// let s = surfaces.sample(Column::floats(&u), [Column::floats(&u), Column::uniform(0.5)])?;
    /// assert!(s.pdf.iter().all(|&p| p > 0.0) && !s.delta[0]);
    /// assert!((s.weight.get(2)[0] - 0.5).abs() < 1e-5);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    ///
    /// A wrong number of `eta` columns, or a column with values for fewer
    /// points than the batch, is an error.
    pub fn at_batch<'a>(
        &'a self,
        points: &'a ShadingBatch<'a>,
        wo: [Column<'a>; 3],
        eta: &[Column<'a>],
    ) -> Result<SurfaceBatch<'a>, Error> {
        let lanes = self.color_model().lanes();
        if eta.len() != lanes {
            return Err(Error::plain(format!(
                "`eta` needs {lanes} columns (the color model's lanes), not {}",
                eta.len()
            )));
        }
        for (name, c) in [("wo", &wo[..]), ("eta", eta)] {
            for (k, c) in c.iter().enumerate() {
                c.check(points.len(), || format!("column {k} of `{name}`"))?;
            }
        }
        Ok(SurfaceBatch { material: self, points, wo, eta: eta.to_vec(), records: None })
    }
}

impl<'a> SurfaceBatch<'a> {
    fn n(&self) -> usize {
        self.points.len()
    }

    fn lanes(&self) -> usize {
        self.material.color_model().lanes()
    }

    /// Runs `f` over the batch with `args`; its result words point by point.
    fn run(&self, f: &Function, args: &[Column], results: usize) -> Result<Vec<u32>, Error> {
        let mut out = vec![0u32; self.n() * results];
        f.call_batch(JIT, self.points, args, &mut out, Layout::PointMajor)?;
        Ok(out)
    }

    /// Calls the hit group's `method` with each point's record (the
    /// per-hit stage runs at the first call that needs it) and `own`
    /// columns; `None` when the material has no group or the group no such
    /// method.
    fn prepared(&mut self, method: HitMethod, own: &[Column], results: usize) -> Result<Option<Vec<u32>>, Error> {
        let material: &'a Material = self.material;
        let Some(hit) = material.code.hit.as_ref().map(|h| &h.material) else { return Ok(None) };
        let Some(f) = hit.method_function(method) else { return Ok(None) };
        if self.records.is_none() {
            let stage: Vec<Column> = self.wo.iter().chain(&self.eta).copied().collect();
            self.records = Some(self.run(hit.prepare_function(), &stage, hit.record_words())?);
        }
        let (records, words) = (self.records.as_deref().unwrap_or_default(), hit.record_words());
        let mut args: Vec<Column> = (0..words).map(|k| Column::words_strided(records, k, words)).collect();
        args.extend_from_slice(own);
        self.run(f, &args, results).map(Some)
    }

    /// Interface method `method` with `args` (prepared `own` when its hit
    /// group serves it); zeros when the material has no entry for it.
    fn method(&mut self, method: Method, own: &[Column], args: &[Column], results: usize) -> Result<Vec<u32>, Error> {
        if let Some(out) = self.prepared(HitMethod::Interface(method), own, results)? {
            return Ok(out);
        }
        match &self.material.code.methods[method as usize] {
            Some(f) => self.run(f, args, results),
            None => Ok(vec![0; self.n() * results]),
        }
    }

    /// The result words as colors, in the words' own allocation (a
    /// collect from a vector's iterator into one of the same layout reuses
    /// it): a batch's results are not copied again.
    fn colors(&self, words: Vec<u32>) -> ColorBatch {
        ColorBatch { lanes: self.lanes(), values: words.into_iter().map(f32::from_bits).collect() }
    }

    fn check_lanes(&self, name: &str, columns: &[Column]) -> Result<(), Error> {
        let lanes = self.lanes();
        if columns.len() != lanes {
            return Err(Error::plain(format!(
                "`{name}` needs {lanes} columns (the color model's lanes), not {}",
                columns.len()
            )));
        }
        Ok(())
    }

    // ---------------------------------------------------------- the interface

    /// [`Surface::reflection`] at every point: light `light` from `wi`.
    pub fn reflection(&mut self, wi: [Column<'_>; 3], light: &[Column<'_>]) -> Result<ColorBatch, Error> {
        self.check_lanes("light", light)?;
        let (own, args) = (cat(&[&wi, light]), cat(&[&wi, light, &self.wo]));
        let out = self.method(Method::Reflection, &own, &args, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::refraction`] at every point.
    pub fn refraction(&mut self, wi: [Column<'_>; 3], light: &[Column<'_>]) -> Result<ColorBatch, Error> {
        self.check_lanes("light", light)?;
        let args = cat(&[&wi, light, &self.eta, &self.wo]);
        let out = self.method(Method::Refraction, &[], &args, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::refraction_index`] at every point.
    pub fn refraction_index(&mut self) -> Result<ColorBatch, Error> {
        if let Some(ior) = &self.material.facts().constant_ior {
            let mut c = ColorBatch::zeros(self.n(), self.lanes());
            for point in c.values.chunks_exact_mut(self.lanes().max(1)) {
                point[..ior.len()].copy_from_slice(ior);
            }
            return Ok(c);
        }
        let out = self.method(Method::RefractionIndex, &[], &[], self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::reflection_dir`] at every point.
    pub fn reflection_dir(&mut self) -> Result<Vec<[f32; 3]>, Error> {
        let wo = self.wo;
        Ok(vectors(&self.method(Method::ReflectionDir, &[], &wo, 3)?))
    }

    /// [`Surface::refraction_dir`] at every point.
    pub fn refraction_dir(&mut self) -> Result<Vec<[f32; 3]>, Error> {
        let args = cat(&[&self.wo, &self.eta]);
        Ok(vectors(&self.method(Method::RefractionDir, &[], &args, 3)?))
    }

    /// [`Surface::emission`] at every point.
    pub fn emission(&mut self) -> Result<ColorBatch, Error> {
        if !self.material.facts().may_emit {
            return Ok(ColorBatch::zeros(self.n(), self.lanes()));
        }
        let wo = self.wo;
        let out = self.method(Method::Emission, &[], &wo, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::albedo`] at every point: the fraction of light from `wo`
    /// each point reflects.
    pub fn albedo(&mut self) -> Result<ColorBatch, Error> {
        let wo = self.wo;
        let out = self.method(Method::Albedo, &[], &wo, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::ambient`] at every point.
    pub fn ambient(&mut self, light: &[Column<'_>]) -> Result<ColorBatch, Error> {
        self.check_lanes("light", light)?;
        let out = self.method(Method::Ambient, &[], light, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::absorption`] at every point.
    pub fn absorption(&mut self, light: &[Column<'_>], distance: Column<'_>) -> Result<ColorBatch, Error> {
        self.check_lanes("light", light)?;
        if self.material.facts().clear {
            let n = self.n();
            distance.check(n, || "`distance`".into())?;
            for (k, c) in light.iter().enumerate() {
                c.check(n, || format!("column {k} of `light`"))?;
            }
            let mut c = ColorBatch::zeros(n, self.lanes());
            for (i, point) in c.values.chunks_exact_mut(self.lanes().max(1)).enumerate() {
                for (x, column) in point.iter_mut().zip(light) {
                    *x = f32::from_bits(column.word(i));
                }
            }
            return Ok(c);
        }
        let args = cat(&[light, &[distance]]);
        let out = self.method(Method::Absorption, &[], &args, self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::normal`] at every point.
    pub fn normal(&mut self) -> Result<Vec<[f32; 3]>, Error> {
        Ok(vectors(&self.method(Method::Normal, &[], &[], 3)?))
    }

    /// [`Surface::diffuse`] at every point.
    pub fn diffuse(&mut self) -> Result<ColorBatch, Error> {
        let out = self.method(Method::Diffuse, &[], &[], self.lanes())?;
        Ok(self.colors(out))
    }

    /// [`Surface::opaque`] at every point.
    pub fn opaque(&mut self) -> Result<Vec<bool>, Error> {
        if self.material.facts().always_opaque {
            return Ok(vec![true; self.n()]);
        }
        Ok(self.method(Method::Opaque, &[], &[], 1)?.iter().map(|w| *w != 0).collect())
    }

    /// [`Surface::sample`] at every point, from the uniform numbers `uc`
    /// (which lobe) and `u` (where in it).
    pub fn sample(&mut self, uc: Column<'_>, u: [Column<'_>; 2]) -> Result<SampleBatch, Error> {
        let own = cat(&[&[uc], &u]);
        let args = cat(&[&self.wo, &self.eta, &own]);
        let layout = SampleLayout { lanes: self.lanes() };
        let words = layout.words();
        let out = self.method(Method::Sample, &own, &args, words)?;
        let points = || out.chunks_exact(words);
        Ok(SampleBatch {
            wi: points().map(|p| vector(&p[SampleLayout::WI])).collect(),
            weight: self.colors(points().flat_map(|p| &p[layout.weight()]).copied().collect::<Vec<u32>>()),
            pdf: points().map(|p| f32::from_bits(p[layout.pdf()])).collect(),
            delta: points().map(|p| f32::from_bits(p[layout.delta()]) > 0.0).collect(),
        })
    }

    /// [`Surface::pdf`] at every point.
    pub fn pdf(&mut self, wi: [Column<'_>; 3]) -> Result<Vec<f32>, Error> {
        let args = cat(&[&wi, &self.wo, &self.eta]);
        Ok(self.method(Method::Pdf, &[], &args, 1)?.iter().map(|w| f32::from_bits(*w)).collect())
    }

    /// [`Surface::eval_pdf`] at every point.
    pub fn eval_pdf(&mut self, wi: [Column<'_>; 3]) -> Result<EvalPdfBatch, Error> {
        let layout = EvalPdfLayout { lanes: self.lanes() };
        let words = layout.words();
        let material: &'a Material = self.material;
        let out = match self.prepared(HitMethod::EvalPdf, &wi, words)? {
            Some(out) => Some(out),
            None => match &material.code.eval_pdf {
                Some(f) => Some(self.run(f, &cat(&[&wi, &self.wo, &self.eta]), words)?),
                None => None,
            },
        };
        if let Some(out) = out {
            let points = || out.chunks_exact(words);
            return Ok(EvalPdfBatch {
                value: self.colors(points().flat_map(|p| &p[layout.value()]).copied().collect::<Vec<u32>>()),
                pdf: points().map(|p| f32::from_bits(p[layout.pdf()])).collect(),
            });
        }
        // The methods one by one, as the combined entry computes them.
        let ones = Column::uniforms(&vec![1.0; self.lanes()]);
        let reflection = self.reflection(wi, &ones)?;
        let refraction = self.refraction(wi, &ones)?;
        let pdf = self.pdf(wi)?;
        let mut value = reflection;
        for i in 0..self.n() {
            let g = self.points.point(i);
            let ng = glam::Vec3::from(g.ng);
            let wi_i = glam::Vec3::from([0, 1, 2].map(|k| f32::from_bits(wi[k].word(i))));
            let wo_i = glam::Vec3::from([0, 1, 2].map(|k| f32::from_bits(self.wo[k].word(i))));
            if ng.dot(wi_i) * ng.dot(wo_i) <= 0.0 {
                let lanes = self.lanes();
                value.values[i * lanes..(i + 1) * lanes].copy_from_slice(refraction.get(i));
            }
        }
        Ok(EvalPdfBatch { value, pdf })
    }

    /// [`Surface::delta_lobes`] at every point.
    pub fn delta_lobes(&mut self) -> Result<DeltaLobesBatch, Error> {
        let (n, lanes) = (self.n(), self.lanes());
        let facts = self.material.facts();
        if !facts.reflects && !facts.refracts {
            let none = ColorBatch::zeros(n, lanes);
            return Ok(DeltaLobesBatch {
                reflect_dir: vec![[0.0; 3]; n],
                reflect_weight: none.clone(),
                refract_dir: vec![[0.0; 3]; n],
                refract_weight: none,
            });
        }
        let layout = DeltaLobesLayout { lanes };
        let words = layout.words();
        let material: &'a Material = self.material;
        let out = match self.prepared(HitMethod::DeltaLobes, &[], words)? {
            Some(out) => Some(out),
            None => match &material.code.delta_lobes {
                Some(f) => Some(self.run(f, &cat(&[&self.wo, &self.eta]), words)?),
                None => None,
            },
        };
        let mut lobes = match out {
            Some(out) => {
                let points = || out.chunks_exact(words);
                let weight = |range: std::ops::Range<usize>| {
                    self.colors(points().flat_map(|p| &p[range.clone()]).copied().collect::<Vec<u32>>())
                };
                DeltaLobesBatch {
                    reflect_dir: points().map(|p| vector(&p[DeltaLobesLayout::REFLECT_DIR])).collect(),
                    reflect_weight: weight(layout.reflect_weight()),
                    refract_dir: points().map(|p| vector(&p[layout.refract_dir()])).collect(),
                    refract_weight: weight(layout.refract_weight()),
                }
            }
            None => {
                let ones = Column::uniforms(&vec![1.0; lanes]);
                let reflect_dir = self.reflection_dir()?;
                let reflect_weight = self.reflection(Column::vectors(&reflect_dir), &ones)?;
                let refract_dir = self.refraction_dir()?;
                let refract_weight = self.refraction(Column::vectors(&refract_dir), &ones)?;
                DeltaLobesBatch { reflect_dir, reflect_weight, refract_dir, refract_weight }
            }
        };
        // A point without a lobe: zeros, as `DeltaLobes` has `None` there.
        for i in 0..n {
            for (dir, weight) in [
                (&mut lobes.reflect_dir, &mut lobes.reflect_weight),
                (&mut lobes.refract_dir, &mut lobes.refract_weight),
            ] {
                if dir[i] == [0.0; 3] || !dir[i].iter().all(|x| x.is_finite()) {
                    dir[i] = [0.0; 3];
                    weight.values[i * lanes..(i + 1) * lanes].fill(0.0);
                }
            }
        }
        Ok(lobes)
    }
}

fn vector(words: &[u32]) -> [f32; 3] {
    [0, 1, 2].map(|k| f32::from_bits(words[k]))
}

fn vectors(words: &[u32]) -> Vec<[f32; 3]> {
    words.chunks_exact(3).map(vector).collect()
}

/// Argument columns in order, from the parts given.
fn cat<'c>(parts: &[&[Column<'c>]]) -> Vec<Column<'c>> {
    parts.concat()
}
