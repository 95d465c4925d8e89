//! Calls over many points at once: a [`ShadingBatch`] of shading points,
//! argument [`Column`]s (structure of arrays, a field of an array of
//! structs, or one value for every point), and results written point by
//! point into one slice. One native call runs a whole batch, the loop
//! inside the compiled code (`jit::batch`); a host with arrays (a Python
//! program, a wavefront renderer) pays one call per batch, not per point.
//! Results are the same bits as calls point by point.

use super::{Backend, Error, Function};
use crate::globals::{GLOBAL_WORDS, ShadingGlobals};
use crate::jit::{BatchShape, ColumnPtr};

/// One input word of every point of a batch: a slice read with a stride
/// (in words), or one value for every point.
///
/// ```
/// use tsl::Column;
/// let xs = [0.0f32, 0.5, 1.0];
/// let points = [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]];
/// let _every = Column::floats(&xs); // point i reads xs[i]
/// let _y = Column::field(&points, 1); // point i reads points[i][1]
/// let _same = Column::uniform(0.25); // every point reads 0.25
/// assert_eq!(Column::field(&points, 1).len(), Some(2));
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Column<'a> {
    source: Source<'a>,
}

#[derive(Debug, Clone, Copy)]
enum Source<'a> {
    /// Point `i` reads `words[first + i * stride]` (`stride` > 0).
    Slice { words: &'a [u32], first: usize, stride: usize },
    /// Every point reads this word.
    Uniform(u32),
}

impl<'a> Column<'a> {
    /// Point `i` reads `values[i]`.
    pub fn floats(values: &'a [f32]) -> Column<'a> {
        Column::words(bytemuck::cast_slice(values))
    }

    /// Point `i` reads `values[i]` (`int` parameters).
    pub fn ints(values: &'a [i32]) -> Column<'a> {
        Column::words(bytemuck::cast_slice(values))
    }

    /// Point `i` reads the raw word `values[i]` (f32 bits, i32, or a bool
    /// as 0 or 1).
    pub fn words(values: &'a [u32]) -> Column<'a> {
        Column { source: Source::Slice { words: values, first: 0, stride: 1 } }
    }

    /// Point `i` reads `values[i][k]`: one field of an array of vectors
    /// (a numpy array of shape `(n, N)`), with no copy. `k` must be below `N`.
    ///
    /// # Panics
    /// When `k >= N`.
    pub fn field<const N: usize>(values: &'a [[f32; N]], k: usize) -> Column<'a> {
        assert!(k < N, "field {k} of a {N}-wide array");
        Column::strided(bytemuck::cast_slice(values.as_flattened()), k, N)
    }

    /// Point `i` reads `values[first + i * stride]` (a column of a
    /// row-major matrix, say). A stride of 0 reads `values[first]` at
    /// every point.
    pub fn strided(values: &'a [f32], first: usize, stride: usize) -> Column<'a> {
        let words: &[u32] = bytemuck::cast_slice(values);
        if stride == 0 {
            // One value for all; a missing one shows in `len` as no points.
            return match words.get(first) {
                Some(&w) => Column { source: Source::Uniform(w) },
                None => Column { source: Source::Slice { words: &[], first: 0, stride: 1 } },
            };
        }
        Column { source: Source::Slice { words, first, stride } }
    }

    /// Point `i` reads `words[first + i * stride]` (`stride` > 0): a word
    /// of records stored point by point.
    pub(super) fn words_strided(words: &'a [u32], first: usize, stride: usize) -> Column<'a> {
        Column { source: Source::Slice { words, first, stride: stride.max(1) } }
    }

    /// Every point reads `value`.
    pub fn uniform(value: f32) -> Column<'static> {
        Column { source: Source::Uniform(value.to_bits()) }
    }

    /// Every point reads the raw word `word`.
    pub fn uniform_word(word: u32) -> Column<'static> {
        Column { source: Source::Uniform(word) }
    }

    /// The three columns of an array of vectors (`P`, `wi`, ...).
    pub fn vectors(values: &'a [[f32; 3]]) -> [Column<'a>; 3] {
        [0, 1, 2].map(|k| Column::field(values, k))
    }

    /// The `lanes` columns of colors stored point by point (`values` is
    /// `n × lanes`, row-major): one column per lane.
    pub fn colors(values: &'a [f32], lanes: usize) -> Vec<Column<'a>> {
        (0..lanes).map(|k| Column::strided(values, k, lanes)).collect()
    }

    /// One vector for every point (a direction all points share).
    pub fn uniform_vector(v: [f32; 3]) -> [Column<'static>; 3] {
        v.map(Column::uniform)
    }

    /// One value for every point in each of `lanes` (a color's lanes).
    pub fn uniforms(lanes: &[f32]) -> Vec<Column<'static>> {
        lanes.iter().map(|&x| Column::uniform(x)).collect()
    }

    /// How many points the column has values for (`None`: any number).
    pub fn len(&self) -> Option<usize> {
        match self.source {
            Source::Uniform(_) => None,
            Source::Slice { words, first, stride } => {
                Some(if first >= words.len() { 0 } else { (words.len() - first - 1) / stride + 1 })
            }
        }
    }

    /// Whether the column has values for no point at all.
    pub fn is_empty(&self) -> bool {
        self.len() == Some(0)
    }

    /// The word point `i` reads (`i` within [`Column::len`]).
    pub(super) fn word(&self, i: usize) -> u32 {
        match self.source {
            Source::Uniform(w) => w,
            Source::Slice { words, first, stride } => words[first + i * stride],
        }
    }

    /// Where the compiled loop reads it. Valid while `self` is borrowed:
    /// a uniform's word lives in the column itself.
    fn pointer(&self) -> ColumnPtr {
        match &self.source {
            Source::Uniform(w) => ColumnPtr { base: w, stride: 0 },
            Source::Slice { words, first, stride } => {
                ColumnPtr { base: words[*first..].as_ptr(), stride: (stride * 4) as isize }
            }
        }
    }

    /// An error unless the column has values for `points` points.
    pub(super) fn check(&self, points: usize, what: impl FnOnce() -> String) -> Result<(), Error> {
        match self.len() {
            Some(n) if n < points => {
                Err(Error::plain(format!("{} has values for {n} points, and the batch has {points}", what())))
            }
            _ => Ok(()),
        }
    }
}

/// How a batch's results are laid out in the slice they are written to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Layout {
    /// Point by point: point `i`'s result words at `i * words ..` (an
    /// array of structs; a numpy array of shape `(n, words)`).
    PointMajor,
    /// Word by word: result word `k` of point `i` at `k * n + i` (a
    /// structure of arrays; a numpy array of shape `(words, n)`).
    WordMajor,
}

/// The shading points of a batch: each global is one value for every point
/// (from a base [`ShadingGlobals`]) unless a column gives it point by point.
///
/// ```
/// use tsl::{Column, ShadingBatch};
/// let p = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0]];
/// let mut batch = ShadingBatch::new(2);
/// batch.set_vectors("P", &p)?.set("u", &[Column::floats(&[0.25, 0.75])])?;
/// let err = batch.set_vectors("Q", &p).unwrap_err();
/// assert!(err.to_string().contains("no global `Q`"), "{err}");
/// # Ok::<(), tsl::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct ShadingBatch<'a> {
    points: usize,
    base: ShadingGlobals,
    /// By globals word.
    columns: Vec<Option<Column<'a>>>,
}

impl<'a> ShadingBatch<'a> {
    /// `points` shading points, every global at its default
    /// ([`ShadingGlobals::default`]) until set.
    pub fn new(points: usize) -> ShadingBatch<'a> {
        ShadingBatch::with_base(points, ShadingGlobals::default())
    }

    /// `points` shading points whose globals are those of `base` until set.
    pub fn with_base(points: usize, base: ShadingGlobals) -> ShadingBatch<'a> {
        ShadingBatch { points, base, columns: vec![None; GLOBAL_WORDS as usize] }
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.points
    }

    pub fn is_empty(&self) -> bool {
        self.points == 0
    }

    /// Gives the global `name` (`P`, `N`, `u`, `face`, ...) point by point:
    /// one column per word (three for a point, vector or normal). An
    /// unknown name, a wrong number of columns, or a column with values for
    /// fewer points than the batch is an error.
    pub fn set(&mut self, name: &str, columns: &[Column<'a>]) -> Result<&mut Self, Error> {
        let Some((word, ty)) = crate::globals::word_of(name) else {
            let names = crate::check::GLOBALS.iter().map(|(n, _, _)| *n);
            let hint =
                crate::diag::did_you_mean(name, names).map(|s| format!("; did you mean `{s}`?")).unwrap_or_default();
            return Err(Error::plain(format!("no global `{name}`{hint}")));
        };
        let words = if ty.is_triple() { 3 } else { 1 };
        if columns.len() != words {
            return Err(Error::plain(format!("`{name}` is a {ty}: {words} columns, not {}", columns.len())));
        }
        for (k, c) in columns.iter().enumerate() {
            c.check(self.points, || format!("column {k} of `{name}`"))?;
            self.columns[word as usize + k] = Some(*c);
        }
        Ok(self)
    }

    /// [`ShadingBatch::set`] from an array of vectors, one per point.
    pub fn set_vectors(&mut self, name: &str, values: &'a [[f32; 3]]) -> Result<&mut Self, Error> {
        self.set(name, &Column::vectors(values))
    }

    /// [`ShadingBatch::set`] from one float per point.
    pub fn set_floats(&mut self, name: &str, values: &'a [f32]) -> Result<&mut Self, Error> {
        self.set(name, &[Column::floats(values)])
    }

    /// The globals of point `i` (for calls point by point, and tests).
    pub fn point(&self, i: usize) -> ShadingGlobals {
        let mut words = self.base.words();
        for (w, c) in words.iter_mut().zip(&self.columns) {
            if let Some(c) = c {
                *w = c.word(i);
            }
        }
        ShadingGlobals::from_words(&words)
    }
}

/// The most result words × points one batch call writes, and the most
/// points: far beyond any host's arrays, it keeps index arithmetic exact.
pub const MAX_BATCH_WORDS: usize = 1 << 40;

impl Function {
    /// Calls the function at every point of `points`: argument word `k` of
    /// point `i` from `args[k]`, the result words into `out` as `layout`
    /// says. One native call for the whole batch (the loop is in the
    /// compiled code; its batch form is compiled the first time a batch is
    /// run), and the same bits as [`Function::call_words`] point by point.
    ///
    /// ```
    /// use tsl::{Backend, Column, Layout, ShadingBatch};
    /// let p = tsl::Compiler::new().source("t.tsl", "float f(float k) { return u * k; }").compile()?;
    /// let f = p.function("f").expect("defined");
    /// let mut batch = ShadingBatch::new(3);
    /// batch.set_floats("u", &[1.0, 2.0, 3.0])?;
    /// let mut out = [0u32; 3];
    /// f.call_batch(Backend::Jit, &batch, &[Column::uniform(0.5)], &mut out, Layout::PointMajor)?;
    /// assert_eq!(out.map(f32::from_bits), [0.5, 1.0, 1.5]);
    /// # Ok::<(), tsl::Error>(())
    /// ```
    ///
    /// A wrong number of argument columns, a column or `out` too short
    /// for the batch, is an error and nothing runs.
    pub fn call_batch(
        &self,
        backend: Backend,
        points: &ShadingBatch,
        args: &[Column],
        out: &mut [u32],
        layout: Layout,
    ) -> Result<(), Error> {
        let (params, results, _) = self.words;
        let n = points.len();
        if args.len() != params {
            return Err(Error::plain(format!("`{}` takes {params} argument columns, not {}", self.name(), args.len())));
        }
        for (k, c) in args.iter().enumerate() {
            c.check(n, || format!("argument column {k} of `{}`", self.name()))?;
        }
        let needed = n.checked_mul(results).filter(|&w| w <= MAX_BATCH_WORDS && n <= MAX_BATCH_WORDS);
        match needed {
            Some(w) if out.len() >= w => {}
            _ => {
                return Err(Error::plain(format!(
                    "`{}` writes {results} words for each of {n} points: `out` holds {}",
                    self.name(),
                    out.len()
                )));
            }
        }
        if n == 0 {
            return Ok(());
        }
        let instance = self.instance_block().map_err(Error::plain)?;
        match backend {
            Backend::Interpreter => {
                let mut arg_words = vec![0u32; params];
                let mut result = vec![0u32; results];
                for i in 0..n {
                    let g = points.point(i).words();
                    for (w, c) in arg_words.iter_mut().zip(args) {
                        *w = c.word(i);
                    }
                    crate::interp::run_instance(self.ir(), &g, &arg_words, instance, &mut result);
                    for (k, w) in result.iter().enumerate() {
                        out[out_index(layout, n, results, i, k)] = *w;
                    }
                }
            }
            Backend::Jit => {
                let code = self.batch_code().map_err(Error::plain)?;
                let base = points.base.words();
                let globals: Vec<ColumnPtr> = (0..GLOBAL_WORDS as usize)
                    .map(|w| match &points.columns[w] {
                        Some(c) => c.pointer(),
                        None => ColumnPtr { base: &base[w], stride: 0 },
                    })
                    .collect();
                let arg_columns: Vec<ColumnPtr> = args.iter().map(Column::pointer).collect();
                let out_base = out.as_mut_ptr();
                let out_columns: Vec<ColumnPtr> = (0..results)
                    .map(|k| {
                        let first = out_index(layout, n, results, 0, k);
                        let stride = out_index(layout, n, results, 1, k) - first;
                        ColumnPtr { base: out_base.wrapping_add(first), stride: (4 * stride) as isize }
                    })
                    .collect();
                // SAFETY: the batch entry was compiled around this
                // function's code for its globals reads and word counts
                // (`batch_code`); every column was checked above to hold
                // `n` points (uniform columns and the base words are read
                // at stride 0 and outlive the call), `out` holds `n *
                // results` words in `layout`, and the instance block is
                // the function's own, checked by `instance_block`.
                unsafe {
                    (code.entry())(globals.as_ptr(), arg_columns.as_ptr(), out_columns.as_ptr(), instance.as_ptr(), n)
                };
            }
        }
        Ok(())
    }

    /// The batch form of the function's code, compiled on first use.
    fn batch_code(&self) -> Result<&crate::jit::BatchCode, String> {
        let cell = &self.part.batches[self.index];
        cell.get_or_init(|| {
            let f = self.ir();
            let mut read = Vec::new();
            crate::ir::for_each_op(&f.body, &mut |op| {
                if let crate::ir::Op::Global(w) = op
                    && !read.contains(w)
                {
                    read.push(*w);
                }
            });
            read.sort_unstable();
            let shape = BatchShape { globals_read: &read, arg_words: f.params.len(), result_words: f.results.len() };
            // Four points at a time where the machine's vectors allow
            // (bit for bit what the point entry computes), else one.
            if let Ok(code) = crate::jit::compile_batch_simd(f, &shape) {
                return Ok(code);
            }
            // SAFETY: `self.native` is this IR function's code, which
            // reads only the globals words found above and its own argument
            // words, and writes its result words; the batch code is kept in
            // the same part, which keeps that code alive.
            unsafe { crate::jit::compile_batch(self.native, &shape) }
        })
        .as_ref()
        .map_err(Clone::clone)
    }
}

/// Where result word `k` of point `i` goes in a batch of `n` points of
/// `words` result words each.
fn out_index(layout: Layout, n: usize, words: usize, i: usize, k: usize) -> usize {
    match layout {
        Layout::PointMajor => i * words + k,
        Layout::WordMajor => k * n + i,
    }
}
