//! The reference interpreter of the IR: the oracle the JIT is tested
//! against. Small and direct on purpose; speed is the JIT's job.
//!
//! Every operation here must give the same bits as the JIT's: natives are
//! the same Rust functions, and the semantics of `FMin`, integer division,
//! index clamping, conversions and loop limits are `ir::semantics`'s, which
//! this module calls rather than restates. It depends on `ir`, the runtime
//! natives and textures only, never on the front end.

use crate::ir::semantics::{
    MAX_CALL_ITERATIONS, clamp_index, float_to_int, fmax, fmin, int_div, int_rem, loop_trips, table_index,
};
use crate::ir::{BinOp, Function, Inst, Label, Op, UnOp};
use crate::runtime::native;
use crate::texture::Lookup;

/// Runs `func` on the given globals and argument words, writing the result
/// words into `out`.
pub fn run(func: &Function, globals: &[u32], args: &[u32], out: &mut [u32]) {
    run_with(func, globals, args, &[], out, None);
}

/// [`run`] for a function that reads an instance parameter block
/// (`Op::InstanceWord`): `instance` holds its words.
pub fn run_instance(func: &Function, globals: &[u32], args: &[u32], instance: &[u32], out: &mut [u32]) {
    run_with(func, globals, args, instance, out, None);
}

/// What one interpreted call evaluated: the profile
/// [`Function::count_ops`](crate::Function::count_ops) returns, as OSL's
/// shader profiling counts what a shading call ran. Counts depend on the
/// program, the arguments and the shading point, never on timing; add
/// them up over calls with `+=`.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct OpCounts {
    /// IR operations evaluated (arithmetic, comparisons, loads, constants,
    /// native calls), each loop body's once per trip.
    pub operations: u64,
    /// Calls of native functions (math beyond the IR's instructions, cell
    /// noise, noise at the sites past the ones lowering expands inline).
    pub native_calls: u64,
    /// Texture lookups (`texture()` calls evaluated).
    pub texture_lookups: u64,
    /// Noise evaluations: native calls (`tsl_noise3`, `tsl_cellnoise3`, ...)
    /// and inline expansions, each of which reads its gradient table at the
    /// 2, 4 or 8 corners of a 1D, 2D or 3D lattice cell and counts as
    /// 1/2, 1/4 or 1/8 per read (so a whole expansion counts 1).
    pub noise: f64,
}

impl std::ops::AddAssign for OpCounts {
    fn add_assign(&mut self, other: OpCounts) {
        self.operations += other.operations;
        self.native_calls += other.native_calls;
        self.texture_lookups += other.texture_lookups;
        self.noise += other.noise;
    }
}

/// [`run_instance`], returning what it evaluated.
pub fn run_counting(func: &Function, globals: &[u32], args: &[u32], instance: &[u32], out: &mut [u32]) -> OpCounts {
    let mut counts = OpCounts::default();
    run_with(func, globals, args, instance, out, Some(&mut counts));
    counts
}

fn run_with(
    func: &Function,
    globals: &[u32],
    args: &[u32],
    instance: &[u32],
    out: &mut [u32],
    counts: Option<&mut OpCounts>,
) {
    // A bool argument is true when its word is non-zero, as in the JIT.
    let args: Vec<u32> = args
        .iter()
        .zip(func.params.iter().map(Some).chain(std::iter::repeat(None)))
        .map(|(w, ty)| if ty == Some(&crate::ir::Scalar::Bool) { bw(*w != 0) } else { *w })
        .collect();
    let mut m = Machine {
        globals,
        args: &args,
        instance,
        values: vec![0; func.values.len()],
        vars: vec![0; func.vars.len()],
        arrays: func.arrays.iter().map(|(_, n)| vec![0u32; *n as usize]).collect(),
        budget: MAX_CALL_ITERATIONS,
        out,
        counts,
    };
    let _ = m.body(&func.body);
}

/// How a body ended.
enum Flow {
    Normal,
    Break(Label),
    Continue(Label),
}

struct Machine<'a, 'o> {
    globals: &'a [u32],
    args: &'a [u32],
    instance: &'a [u32],
    values: Vec<u32>,
    vars: Vec<u32>,
    arrays: Vec<Vec<u32>>,
    /// Loop iterations this call may still run, over all loops.
    budget: i64,
    out: &'o mut [u32],
    counts: Option<&'o mut OpCounts>,
}

fn f(x: u32) -> f32 {
    f32::from_bits(x)
}

fn i(x: u32) -> i32 {
    x as i32
}

fn fw(x: f32) -> u32 {
    x.to_bits()
}

fn iw(x: i32) -> u32 {
    x as u32
}

fn bw(x: bool) -> u32 {
    u32::from(x)
}

impl Machine<'_, '_> {
    fn v(&self, v: crate::ir::Value) -> u32 {
        self.values[v.0 as usize]
    }

    fn body(&mut self, body: &[Inst]) -> Flow {
        for inst in body {
            match inst {
                Inst::Def(v, op) => {
                    if let Some(c) = &mut self.counts {
                        c.operations += 1;
                    }
                    let x = self.op(op);
                    self.values[v.0 as usize] = x;
                }
                Inst::Set(var, v) => self.vars[var.0 as usize] = self.v(*v),
                Inst::Store { array, index, value } => {
                    let a = &mut self.arrays[array.0 as usize];
                    let k = clamp_index(i(self.values[index.0 as usize]), a.len());
                    a[k] = self.values[value.0 as usize];
                }
                Inst::Output(k, v) => self.out[*k as usize] = self.v(*v),
                Inst::Texture { sampler, coords, out } => {
                    if let Some(c) = &mut self.counts {
                        c.texture_lookups += 1;
                    }
                    let c: Vec<f32> = coords.iter().map(|&c| f(self.v(c))).collect();
                    let q = Lookup { s: c[0], t: c[1], dsdx: c[2], dtdx: c[3], dsdy: c[4], dtdy: c[5] };
                    let result: Vec<f32> = if sampler.0.spectral.is_some() {
                        let mut lanes = vec![0.0; sampler.0.spectral_lanes()];
                        sampler.0.sample_spectrum(&q, &[c[6], c[7], c[8], c[9]], &mut lanes);
                        lanes
                    } else {
                        sampler.0.sample(&q).to_vec()
                    };
                    for (word, x) in self.arrays[out.0 as usize].iter_mut().zip(result) {
                        *word = fw(x);
                    }
                }
                Inst::If { cond, then_body, else_body } => {
                    let flow = if self.v(*cond) != 0 { self.body(then_body) } else { self.body(else_body) };
                    if !matches!(flow, Flow::Normal) {
                        return flow;
                    }
                }
                Inst::Block { label, body } => match self.body(body) {
                    Flow::Break(l) if l == *label => {}
                    Flow::Normal => {}
                    other => return other,
                },
                Inst::Loop { label, counter, start, end, body } => {
                    let (start, end) = (i(self.v(*start)), i(self.v(*end)));
                    let trips = loop_trips(start, end);
                    for k in 0..trips {
                        if self.budget <= 0 {
                            break;
                        }
                        self.budget -= 1;
                        self.vars[counter.0 as usize] = iw((i64::from(start) + k) as i32);
                        match self.body(body) {
                            Flow::Normal => {}
                            Flow::Continue(l) if l == *label => {}
                            Flow::Break(l) if l == *label => break,
                            other => return other,
                        }
                    }
                }
                Inst::Break(l) => return Flow::Break(*l),
                Inst::Continue(l) => return Flow::Continue(*l),
            }
        }
        Flow::Normal
    }

    fn op(&mut self, op: &Op) -> u32 {
        match op {
            Op::F32(x) => fw(*x),
            Op::I32(x) => iw(*x),
            Op::Bool(b) => bw(*b),
            Op::Param(k) => self.args[*k as usize],
            Op::Global(k) => self.globals[*k as usize],
            Op::InstanceWord(k) => self.instance[*k as usize],
            Op::Get(var) => self.vars[var.0 as usize],
            Op::Table { table, index } => {
                if let Some(c) = &mut self.counts {
                    c.noise += match crate::runtime::table_name(table) {
                        Some("grad1") => 0.5,
                        Some("grad2.x") => 0.25,
                        Some("grad3.x") => 0.125,
                        _ => 0.0,
                    };
                }
                table[table_index(i(self.v(*index)), table.len())]
            }
            Op::Load { array, index } => {
                let a = &self.arrays[array.0 as usize];
                a[clamp_index(i(self.v(*index)), a.len())]
            }
            Op::Unary(u, a) => {
                let a = self.v(*a);
                match u {
                    UnOp::FNeg => fw(-f(a)),
                    UnOp::FAbs => fw(f(a).abs()),
                    UnOp::Sqrt => fw(f(a).sqrt()),
                    UnOp::Floor => fw(f(a).floor()),
                    UnOp::Ceil => fw(f(a).ceil()),
                    UnOp::Trunc => fw(f(a).trunc()),
                    UnOp::INeg => iw(i(a).wrapping_neg()),
                    UnOp::Not => bw(a == 0),
                    UnOp::IToF => fw(i(a) as f32),
                    UnOp::FToI => iw(float_to_int(f(a))),
                }
            }
            Op::Binary(b, x, y) => {
                let (x, y) = (self.v(*x), self.v(*y));
                match b {
                    BinOp::FAdd => fw(f(x) + f(y)),
                    BinOp::FSub => fw(f(x) - f(y)),
                    BinOp::FMul => fw(f(x) * f(y)),
                    BinOp::FDiv => fw(f(x) / f(y)),
                    BinOp::FMin => fw(fmin(f(x), f(y))),
                    BinOp::FMax => fw(fmax(f(x), f(y))),
                    BinOp::IAdd => iw(i(x).wrapping_add(i(y))),
                    BinOp::ISub => iw(i(x).wrapping_sub(i(y))),
                    BinOp::IMul => iw(i(x).wrapping_mul(i(y))),
                    BinOp::IDiv => iw(int_div(i(x), i(y))),
                    BinOp::IRem => iw(int_rem(i(x), i(y))),
                    BinOp::IAnd => x & y,
                    BinOp::FLt => bw(f(x) < f(y)),
                    BinOp::FLe => bw(f(x) <= f(y)),
                    BinOp::FEq => bw(f(x) == f(y)),
                    BinOp::ILt => bw(i(x) < i(y)),
                    BinOp::ILe => bw(i(x) <= i(y)),
                    BinOp::IEq | BinOp::BEq => bw(x == y),
                    BinOp::And => bw(x != 0 && y != 0),
                    BinOp::Or => bw(x != 0 || y != 0),
                }
            }
            Op::Select { cond, then_value, else_value } => {
                if self.v(*cond) != 0 {
                    self.v(*then_value)
                } else {
                    self.v(*else_value)
                }
            }
            Op::Call { native: name, args } => {
                if let Some(c) = &mut self.counts {
                    c.native_calls += 1;
                    if name.contains("noise") {
                        c.noise += 1.0;
                    }
                }
                let a: Vec<f32> = args.iter().map(|v| f(self.v(*v))).collect();
                let r = native(name).filter(|n| a.len() >= n.arity).map_or(f32::NAN, |n| n.f.call(&a));
                fw(r)
            }
        }
    }
}
