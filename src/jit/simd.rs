//! Four points at a time: a batch entry whose loop runs an IR function over
//! the four lanes of 128-bit vectors (`f32x4`, `i32x4`).
//!
//! Every IR value becomes a vector of its four points' values; a bool is a
//! lane mask (all ones or zero). Control flow becomes predication, as in
//! ISPC: an execution mask says which lanes run the code being emitted.
//! An `if` runs its branches one after the other, each under the mask of
//! its lanes (and skipped when it has none); a loop iterates while any lane
//! still has trips and budget left; `break` and `continue` take their lanes
//! out of the mask until their label's end. Assignments, stores and
//! outputs blend under the mask; everything else is total (the IR's
//! operations cannot trap), so computing it in idle lanes is harmless.
//! What has no vector form runs lane by lane: array and table lookups
//! (gathers), integer division, native calls and texture lookups (called
//! only for running lanes).
//!
//! Each lane computes exactly what the scalar code computes for its point,
//! bit for bit (the same IEEE operations, no fused multiply-adds, the same
//! natives), which tests/batch.rs checks point by point. The last group of
//! a batch repeats its last point in the unused lanes; they compute that
//! point again and write the same bits.

use super::batch::{BatchCode, BatchShape, PointLoop};
use super::{LARGE_FUNCTION, SPECTRUM_TEXTURE_SYMBOL, TEXTURE_SYMBOL, native_isa, safe_div};
use crate::globals::GLOBAL_WORDS;
use crate::ir::semantics::{MAX_CALL_ITERATIONS, MAX_LOOP_ITERATIONS, loop_trips};
use crate::ir::{self, BinOp, Inst, Label, Op, Scalar, UnOp};
use crate::runtime::natives;
use cranelift_codegen::Context;
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{
    AbiParam, FuncRef, InstBuilder, MemFlagsData, Opcode, StackSlot, StackSlotData, StackSlotKind, Type, UserFuncName,
    Value, types,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext, Variable};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{Linkage, Module};
use std::collections::HashMap;
use tables::has_byte_shuffles;

mod tables;

/// Points per iteration of the batch loop.
pub const LANES: usize = 4;

/// Compiles the four-lane batch entry of `f`.
///
/// Errors when the machine's Cranelift back end lacks a vector operation
/// (the caller then uses the point-by-point batch entry).
pub fn compile_batch_simd(f: &ir::Function, shape: &BatchShape) -> Result<BatchCode, String> {
    assert!(shape.globals_read.iter().all(|&w| w < GLOBAL_WORDS), "globals words out of range");
    let isa = native_isa(ir::count_insts(&f.body) > LARGE_FUNCTION)?;
    let mut builder = JITBuilder::with_isa(isa.clone(), cranelift_module::default_libcall_names());
    for n in natives() {
        builder.symbol(n.name, n.ptr);
    }
    builder.symbol(TEXTURE_SYMBOL, crate::texture::tsl_texture as *const u8);
    builder.symbol(SPECTRUM_TEXTURE_SYMBOL, crate::texture::tsl_texture_spectrum as *const u8);
    let mut module = JITModule::new(builder);
    let ptr = module.target_config().pointer_type();

    let mut ctx = Context::new();
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 5]);
    let id = module.declare_function("tsl_batch_simd", Linkage::Local, &sig).map_err(|e| e.to_string())?;
    ctx.func = cranelift_codegen::ir::Function::with_name_signature(UserFuncName::user(0, 0), sig);

    let mut natives_used = HashMap::new();
    for n in natives() {
        let mut nsig = module.make_signature();
        nsig.params.extend((0..n.arity).map(|_| AbiParam::new(types::F32)));
        nsig.returns.push(AbiParam::new(types::F32));
        let nid = module.declare_function(n.name, Linkage::Import, &nsig).map_err(|e| e.to_string())?;
        natives_used.insert(n.name, module.declare_func_in_func(nid, &mut ctx.func));
    }
    let mut texture = Vec::new();
    for (symbol, coords) in [(TEXTURE_SYMBOL, 6), (SPECTRUM_TEXTURE_SYMBOL, 10)] {
        let mut tsig = module.make_signature();
        tsig.params.push(AbiParam::new(ptr));
        tsig.params.extend((0..coords).map(|_| AbiParam::new(types::F32)));
        tsig.params.push(AbiParam::new(ptr));
        let tid = module.declare_function(symbol, Linkage::Import, &tsig).map_err(|e| e.to_string())?;
        texture.push(module.declare_func_in_func(tid, &mut ctx.func));
    }

    let mut fctx = FunctionBuilderContext::new();
    let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
    let slot = |b: &mut FunctionBuilder, words: usize| {
        // 16-byte aligned: whole vectors are loaded and stored.
        b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 4 * words.max(1) as u32, 4))
    };
    let records = Records {
        globals: slot(&mut b, GLOBAL_WORDS as usize * LANES),
        args: slot(&mut b, shape.arg_words * LANES),
        out: slot(&mut b, shape.result_words * LANES),
    };
    let arrays: Vec<StackSlot> = f.arrays.iter().map(|(_, len)| slot(&mut b, *len.max(&1) as usize * LANES)).collect();

    let inputs = |globals: Value, args: Value| {
        [
            (globals, records.globals, shape.globals_read.iter().map(|&w| w as usize).collect::<Vec<_>>()),
            (args, records.args, (0..shape.arg_words).collect()),
        ]
    };
    // A column of stride 0 (one value for every point) is copied into its
    // record once, before the loop, and not again for each group.
    let lp = PointLoop::begin(&mut b, ptr, |b, [globals, args, _, _, points]| {
        let any = b.ins().icmp_imm_u(IntCC::NotEqual, points, 0);
        for (columns, record, words) in inputs(globals, args) {
            for k in words {
                let (base, stride) = column(b, ptr, columns, k);
                let uniform = b.ins().icmp_imm_u(IntCC::Equal, stride, 0);
                let uniform = b.ins().band(uniform, any);
                let (copy, next) = (b.create_block(), b.create_block());
                b.ins().brif(uniform, copy, &[], next, &[]);
                b.switch_to_block(copy);
                let x = b.ins().load(types::I32, MemFlagsData::trusted(), base, 0);
                let x = b.ins().splat(types::I32X4, x);
                b.ins().stack_store(ptr, x, record, (16 * k) as i32);
                b.ins().jump(next, &[]);
                b.switch_to_block(next);
            }
        }
    });
    // A whole group is the points i..i + LANES; the last group of a batch
    // that is not a multiple of LANES repeats its last point in the lanes
    // past the end. Both copy their words in and out apart, around one body.
    let group = |b: &mut FunctionBuilder| {
        let end = b.ins().iadd_imm_u(lp.i, LANES as i64);
        let whole = b.ins().icmp(IntCC::UnsignedLessThanOrEqual, end, lp.points);
        let (whole_b, part_b, join) = (b.create_block(), b.create_block(), b.create_block());
        b.ins().brif(whole, whole_b, &[], part_b, &[]);
        (whole_b, part_b, join)
    };
    let last = |b: &mut FunctionBuilder| b.ins().iadd_imm_s(lp.points, -1);
    let (whole_b, part_b, body) = group(&mut b);
    for (block, lanes) in [(whole_b, GroupLanes::Whole), (part_b, GroupLanes::UpTo)] {
        b.switch_to_block(block);
        let last = last(&mut b);
        for (columns, record, words) in inputs(lp.globals, lp.args) {
            for k in words {
                let stride = column_field(&mut b, ptr, columns, k, 1);
                let (read, next) = (b.create_block(), b.create_block());
                b.ins().brif(stride, read, &[], next, &[]);
                b.switch_to_block(read);
                let base = column_field(&mut b, ptr, columns, k, 0);
                let from = lane_words(&mut b, base, stride, lp.i, lanes, last);
                for (l, from) in from.into_iter().enumerate() {
                    let x = b.ins().load(types::I32, MemFlagsData::trusted(), from, 0);
                    b.ins().stack_store(ptr, x, record, (4 * (k * LANES + l)) as i32);
                }
                b.ins().jump(next, &[]);
                b.switch_to_block(next);
            }
        }
        b.ins().jump(body, &[]);
    }
    b.switch_to_block(body);
    let zeros = b.ins().iconst(types::I32, 0);
    let zeros = b.ins().splat(types::I32X4, zeros);
    for k in 0..shape.result_words {
        b.ins().stack_store(ptr, zeros, records.out, (16 * k) as i32);
    }
    let mut g = Wide::new(&mut b, f, natives_used, [texture[0], texture[1]], ptr, records, arrays, lp.instance);
    g.byte_shuffles = has_byte_shuffles(&*isa);
    g.x86 = isa.name() == "x64";
    g.x86_shuffles = g.byte_shuffles && g.x86;
    g.body(&f.body);
    let tables = std::mem::take(&mut g.padded);

    // Scatter: lanes in order, so a repeated last point is written last
    // by a lane that computed the same bits.
    let (whole_b, part_b, next) = group(&mut b);
    for (block, lanes) in [(whole_b, GroupLanes::Whole), (part_b, GroupLanes::UpTo)] {
        b.switch_to_block(block);
        let last = last(&mut b);
        for k in 0..shape.result_words {
            let (base, stride) = column(&mut b, ptr, lp.out, k);
            let to = lane_words(&mut b, base, stride, lp.i, lanes, last);
            // One load of the word's vector; each lane is stored from it
            // (`pextrd` to memory).
            let words = b.ins().stack_load(ptr, types::I32X4, records.out, (16 * k) as i32);
            for (l, to) in to.into_iter().enumerate() {
                let x = b.ins().extractlane(words, l as u8);
                b.ins().store(MemFlagsData::trusted(), x, to, 0);
            }
        }
        b.ins().jump(next, &[]);
    }
    b.switch_to_block(next);
    lp.end(&mut b, LANES as i64);
    b.finalize(module.target_config());

    Ok(BatchCode::define(module, id, &mut ctx, "a vector batch entry")?.keeping(tables))
}

/// The stack records of one group of points: word `k` of lane `l` at word
/// `k * LANES + l`, so word `k` of all lanes is one vector.
#[derive(Clone, Copy)]
struct Records {
    globals: StackSlot,
    args: StackSlot,
    out: StackSlot,
}

/// Which points the lanes of a group shade.
#[derive(Clone, Copy)]
enum GroupLanes {
    /// Lane `l` shades point `i + l`, all inside the batch.
    Whole,
    /// Lane `l` shades point min(i + l, last): the batch's last group.
    UpTo,
}

/// The base and the stride of column `k` of the column table `columns` (a
/// [`ColumnPtr`](super::batch::ColumnPtr) per word).
fn column(b: &mut FunctionBuilder, ptr: Type, columns: Value, k: usize) -> (Value, Value) {
    (column_field(b, ptr, columns, k, 0), column_field(b, ptr, columns, k, 1))
}

/// Field `field` of column `k` (0: the base, 1: the stride).
fn column_field(b: &mut FunctionBuilder, ptr: Type, columns: Value, k: usize, field: usize) -> Value {
    let table = MemFlagsData::trusted().with_readonly();
    let at = k * std::mem::size_of::<super::batch::ColumnPtr>() + field * std::mem::size_of::<*const u32>();
    b.ins().load(ptr, table, columns, at as i32)
}

/// The addresses of a column's words of the group's points, lane by lane;
/// a whole group's lanes are a stride apart.
fn lane_words(
    b: &mut FunctionBuilder,
    base: Value,
    stride: Value,
    i: Value,
    lanes: GroupLanes,
    last: Value,
) -> [Value; LANES] {
    match lanes {
        GroupLanes::Whole => {
            let offset = b.ins().imul(i, stride);
            let first = b.ins().iadd(base, offset);
            std::array::from_fn(|l| {
                if l == 0 {
                    return first;
                }
                let step = b.ins().imul_imm_s(stride, l as i64);
                b.ins().iadd(first, step)
            })
        }
        GroupLanes::UpTo => std::array::from_fn(|l| {
            let p = b.ins().iadd_imm_u(i, l as i64);
            let p = b.ins().umin(p, last);
            let offset = b.ins().imul(p, stride);
            b.ins().iadd(base, offset)
        }),
    }
}

/// The masks of a label: the lanes that left by `break` (and, for a loop,
/// by `continue`) since its start.
#[derive(Clone, Copy)]
struct LabelMasks {
    exited: Variable,
    continued: Option<Variable>,
}

/// Translates one IR function's body over four lanes.
struct Wide<'a, 'b> {
    b: &'a mut FunctionBuilder<'b>,
    func: &'a ir::Function,
    values: Vec<Option<Value>>,
    vars: Vec<Variable>,
    /// Per lane: loop iterations the point's call may still run.
    budget: Variable,
    /// Whether every lane has the same budget left: no loop has run under
    /// a mask yet (the code runs in order: a loop runs under a mask or
    /// once per call, not inside another loop, [`Wide::uniform_trips`]).
    budget_uniform: bool,
    /// The lanes the code being emitted runs for.
    exec: Variable,
    /// False while `exec` is known to hold every lane (straight-line code
    /// at the top): assignments need no blend.
    masked: bool,
    labels: HashMap<Label, LabelMasks>,
    natives: HashMap<&'static str, FuncRef>,
    texture: [FuncRef; 2],
    ptr: Type,
    records: Records,
    arrays: Vec<StackSlot>,
    instance: Value,
    /// Whether small tables are looked up by byte shuffles
    /// ([`Wide::shuffled_table`]) rather than gathered.
    byte_shuffles: bool,
    /// Whether those shuffles are x86's `pshufb` (SSSE3).
    x86_shuffles: bool,
    /// Whether the code is x86-64's (x86 instructions of Cranelift's).
    x86: bool,
    /// The operation defining each value (to find lookups of adjacent words).
    defs: HashMap<ir::Value, &'a Op>,
    /// Lookups gathered together with the lookup of the next word, by the
    /// value of the first: the second's value ([`Wide::pair_lookups`]).
    paired: HashMap<ir::Value, ir::Value>,
    /// Copies of the tables looked up in pairs with their first word again
    /// at the end, by the address of the table; the code reads them.
    padded: Vec<Box<[u32]>>,
    padded_index: HashMap<*const u32, usize>,
    /// Sixteen bytes of stack for one vector of lookup indices
    /// ([`Wide::table_indices`]), made at the first use.
    indices: Option<StackSlot>,
}

/// The vector type of a scalar type (bools are lane masks).
fn vector(s: Scalar) -> Type {
    match s {
        Scalar::F32 => types::F32X4,
        Scalar::I32 | Scalar::Bool => types::I32X4,
    }
}

impl<'a, 'b> Wide<'a, 'b> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        b: &'a mut FunctionBuilder<'b>,
        func: &'a ir::Function,
        natives: HashMap<&'static str, FuncRef>,
        texture: [FuncRef; 2],
        ptr: Type,
        records: Records,
        arrays: Vec<StackSlot>,
        instance: Value,
    ) -> Self {
        let budget = b.declare_var(types::I32X4);
        let exec = b.declare_var(types::I32X4);
        let mut g = Wide {
            b,
            func,
            values: vec![None; func.values.len()],
            vars: Vec::new(),
            budget,
            budget_uniform: true,
            exec,
            masked: false,
            labels: HashMap::new(),
            natives,
            texture,
            ptr,
            records,
            arrays,
            instance,
            byte_shuffles: false,
            x86_shuffles: false,
            x86: false,
            defs: HashMap::new(),
            paired: HashMap::new(),
            padded: Vec::new(),
            padded_index: HashMap::new(),
            indices: None,
        };
        ir::for_each_inst(&func.body, &mut |inst| {
            if let Inst::Def(v, op) = inst {
                g.defs.insert(*v, op);
            }
        });
        let max = g.splat_i(MAX_CALL_ITERATIONS);
        g.b.def_var(budget, max);
        let all = g.splat_i(-1);
        g.b.def_var(exec, all);
        for ty in &func.vars {
            let var = g.b.declare_var(vector(*ty));
            // Every variable starts at zero in each call, as in the
            // interpreter.
            let zero = g.zero(*ty);
            g.b.def_var(var, zero);
            g.vars.push(var);
        }
        g
    }

    fn splat_i(&mut self, x: i64) -> Value {
        let s = self.b.ins().iconst(types::I32, x);
        self.b.ins().splat(types::I32X4, s)
    }

    fn zero(&mut self, ty: Scalar) -> Value {
        match ty {
            Scalar::F32 => {
                let z = self.b.ins().f32const(0.0);
                self.b.ins().splat(types::F32X4, z)
            }
            Scalar::I32 | Scalar::Bool => self.splat_i(0),
        }
    }

    fn v(&self, v: ir::Value) -> Value {
        self.values[v.0 as usize].expect("IR value used before its definition")
    }

    /// `new` in the lanes of `mask`, `old` elsewhere.
    ///
    /// Cranelift blends in one instruction (`pblendvb`) where it sees that
    /// the mask is whole lanes: the result of a comparison, of the blend's
    /// own type. So the blend is of integer lanes, and a mask computed
    /// otherwise (the lanes that run, `and` of bools) is compared with zero
    /// first: two instructions where `and`, `andn` and `or` are three, and
    /// one comparison serves every blend under the same mask in a block.
    fn blend(&mut self, mask: Value, new: Value, old: Value) -> Value {
        let ty = self.b.func.dfg.value_type(new);
        let compared = self
            .b
            .func
            .dfg
            .value_def(mask)
            .inst()
            .is_some_and(|i| matches!(self.b.func.dfg.insts[i].opcode(), Opcode::Icmp | Opcode::Fcmp));
        let mask = if compared {
            mask
        } else {
            let zero = self.splat_i(0);
            self.b.ins().icmp(IntCC::SignedLessThan, mask, zero)
        };
        let as_ints = |g: &mut Self, x: Value| {
            if ty == types::I32X4 { x } else { g.b.ins().bitcast(types::I32X4, MemFlagsData::new(), x) }
        };
        let (new, old) = (as_ints(self, new), as_ints(self, old));
        let x = self.b.ins().bitselect(mask, new, old);
        if ty == types::I32X4 { x } else { self.b.ins().bitcast(ty, MemFlagsData::new(), x) }
    }

    /// `new` where the code runs, `old` elsewhere (no blend when every
    /// lane runs).
    fn under_exec(&mut self, new: Value, old: impl FnOnce(&mut Self) -> Value) -> Value {
        if !self.masked {
            return new;
        }
        let old = old(self);
        let exec = self.b.use_var(self.exec);
        self.blend(exec, new, old)
    }

    /// A mask as the words 0 and 1 that bools are stored as.
    fn mask_to_words(&mut self, x: Value) -> Value {
        self.b.ins().ushr_imm_u(x, 31)
    }

    fn body(&mut self, body: &[Inst]) {
        self.pair_lookups(body);
        for inst in body {
            self.inst(inst);
        }
    }

    /// The address of word `index` (clamped into the array) of lane `l`'s
    /// copy of `array`.
    fn array_word(&mut self, array: ir::ArrayId, index: Value, l: usize) -> Value {
        let len = self.func.arrays[array.0 as usize].1.max(1);
        let i = self.b.ins().extractlane(index, l as u8);
        let zero = self.b.ins().iconst(types::I32, 0);
        let top = self.b.ins().iconst(types::I32, i64::from(len - 1));
        let i = self.b.ins().smax(i, zero);
        let i = self.b.ins().smin(i, top);
        let i = self.b.ins().iadd_imm_s(i, (l as u32 * len) as i64);
        let wide = self.b.ins().uextend(self.ptr, i);
        let offset = self.b.ins().ishl_imm_u(wide, 2);
        let base = self.b.ins().stack_addr(self.ptr, self.arrays[array.0 as usize], 0);
        self.b.ins().iadd(base, offset)
    }

    /// Runs `emit(lane)` for each lane, inside a test of that lane's
    /// `exec` bit when the code is masked.
    fn per_running_lane(&mut self, mut emit: impl FnMut(&mut Self, usize)) {
        for l in 0..LANES {
            if !self.masked {
                emit(self, l);
                continue;
            }
            let exec = self.b.use_var(self.exec);
            let bit = self.b.ins().extractlane(exec, l as u8);
            let (run, next) = (self.b.create_block(), self.b.create_block());
            self.b.ins().brif(bit, run, &[], next, &[]);
            self.b.switch_to_block(run);
            emit(self, l);
            self.b.ins().jump(next, &[]);
            self.b.switch_to_block(next);
        }
    }

    /// Emits `body` under `mask`, skipping it when no lane is in it;
    /// returns the lanes that come out of its end.
    fn masked_body(&mut self, mask: Value, body: &[Inst]) -> Value {
        self.b.def_var(self.exec, mask);
        if body.is_empty() {
            return mask;
        }
        let (run, after) = (self.b.create_block(), self.b.create_block());
        let any = self.b.ins().vany_true(mask);
        self.b.ins().brif(any, run, &[], after, &[]);
        self.b.switch_to_block(run);
        let masked = std::mem::replace(&mut self.masked, true);
        self.body(body);
        self.masked = masked;
        self.b.ins().jump(after, &[]);
        self.b.switch_to_block(after);
        self.b.use_var(self.exec)
    }

    fn inst(&mut self, inst: &Inst) {
        let trusted = MemFlagsData::trusted();
        match inst {
            // The second of a pair, gathered with the first.
            Inst::Def(v, _) if self.values[v.0 as usize].is_some() => {}
            Inst::Def(v, Op::Table { table, index }) if self.paired.contains_key(v) => {
                self.paired_lookup(*v, table, *index)
            }
            Inst::Def(v, op) => {
                let ty = self.func.value_type(*v);
                let x = self.op(op, ty);
                self.values[v.0 as usize] = Some(x);
            }
            Inst::Set(var, v) => {
                let var = self.vars[var.0 as usize];
                let x = self.v(*v);
                let x = self.under_exec(x, |g| g.b.use_var(var));
                self.b.def_var(var, x);
            }
            Inst::Store { array, index, value } => {
                let (index, x) = (self.v(*index), self.v(*value));
                let x = if self.func.value_type(*value) == Scalar::Bool { self.mask_to_words(x) } else { x };
                self.per_running_lane(|g, l| {
                    let addr = g.array_word(*array, index, l);
                    let xl = g.b.ins().extractlane(x, l as u8);
                    g.b.ins().store(trusted, xl, addr, 0);
                });
            }
            Inst::Texture { sampler, coords, out } => {
                let native = self.texture[usize::from(sampler.0.spectral.is_some())];
                let sampler = std::sync::Arc::as_ptr(&sampler.0) as i64;
                let coords: Vec<Value> = coords.iter().map(|c| self.v(*c)).collect();
                let len = self.func.arrays[out.0 as usize].1.max(1);
                let slot = self.arrays[out.0 as usize];
                self.per_running_lane(|g, l| {
                    let sampler = g.b.ins().iconst(g.ptr, sampler);
                    let dest = g.b.ins().stack_addr(g.ptr, slot, (4 * l as u32 * len) as i32);
                    let mut args = vec![sampler];
                    args.extend(coords.iter().map(|c| g.b.ins().extractlane(*c, l as u8)));
                    args.push(dest);
                    g.b.ins().call(native, &args);
                });
            }
            Inst::Output(k, v) => {
                let x = self.v(*v);
                let x = if self.func.value_type(*v) == Scalar::Bool { self.mask_to_words(x) } else { x };
                let ty = self.b.func.dfg.value_type(x);
                let (out, at) = (self.records.out, (16 * *k) as i32);
                let ptr = self.ptr;
                let x = self.under_exec(x, |g| g.b.ins().stack_load(ptr, ty, out, at));
                self.b.ins().stack_store(ptr, x, out, at);
            }
            Inst::If { cond, then_body, else_body } => {
                let c = self.v(*cond);
                let entry = self.b.use_var(self.exec);
                let then_mask = self.b.ins().band(entry, c);
                let then_out = self.masked_body(then_mask, then_body);
                let else_mask = self.b.ins().band_not(entry, c);
                let else_out = self.masked_body(else_mask, else_body);
                let merged = self.b.ins().bor(then_out, else_out);
                self.b.def_var(self.exec, merged);
                self.masked |= escapes(then_body) || escapes(else_body);
            }
            Inst::Block { label, body } => {
                let exited = self.b.declare_var(types::I32X4);
                let none = self.splat_i(0);
                self.b.def_var(exited, none);
                self.labels.insert(*label, LabelMasks { exited, continued: None });
                let masked = self.masked;
                self.body(body);
                let (fell, left) = (self.b.use_var(self.exec), self.b.use_var(exited));
                let joined = self.b.ins().bor(fell, left);
                self.b.def_var(self.exec, joined);
                // Lanes that broke out of the block are back; lanes that
                // left for an outer label are not.
                self.masked = masked || escapes(std::slice::from_ref(inst));
            }
            Inst::Loop { label, counter, start, end, body } => {
                self.wide_loop(inst, *label, *counter, *start, *end, body)
            }
            Inst::Break(l) => {
                if let Some(m) = self.labels.get(l).copied() {
                    self.leave(m.exited);
                }
            }
            Inst::Continue(l) => {
                if let Some(LabelMasks { continued: Some(c), .. }) = self.labels.get(l).copied() {
                    self.leave(c);
                }
            }
        }
    }

    /// The running lanes jump to a label: they join `to` and stop running.
    fn leave(&mut self, to: Variable) {
        let (exec, so_far) = (self.b.use_var(self.exec), self.b.use_var(to));
        let joined = self.b.ins().bor(so_far, exec);
        self.b.def_var(to, joined);
        let none = self.splat_i(0);
        self.b.def_var(self.exec, none);
        self.masked = true;
    }

    /// `ir::semantics::loop_trips` per lane: clamp(end - start, 0,
    /// MAX_LOOP_ITERATIONS), in 64 bits.
    fn trips(&mut self, start: Value, end: Value) -> Value {
        let mut trips = self.splat_i(0);
        for l in 0..LANES {
            let s = self.b.ins().extractlane(start, l as u8);
            let e = self.b.ins().extractlane(end, l as u8);
            let s = self.b.ins().sextend(types::I64, s);
            let e = self.b.ins().sextend(types::I64, e);
            let d = self.b.ins().isub(e, s);
            let zero = self.b.ins().iconst(types::I64, 0);
            let max = self.b.ins().iconst(types::I64, MAX_LOOP_ITERATIONS);
            let d = self.b.ins().smax(d, zero);
            let d = self.b.ins().smin(d, max);
            let d = self.b.ins().ireduce(types::I32, d);
            trips = self.b.ins().insertlane(trips, d, l as u8);
        }
        trips
    }

    /// The value of `v` when it is defined as an integer constant.
    fn int_constant(&self, v: ir::Value) -> Option<i32> {
        match self.defs.get(&v) {
            Some(Op::I32(c)) => Some(*c),
            _ => None,
        }
    }

    /// The trips of a loop that every lane runs alike, when it is one: all
    /// lanes run it, its bounds are constants, every lane has the same
    /// budget, and its body neither leaves early (`break`, `continue`) nor
    /// holds a loop (which could spend the lanes' budgets unevenly before
    /// the next iteration).
    fn uniform_trips(&self, start: ir::Value, end: ir::Value, body: &[Inst]) -> Option<(i32, i64)> {
        fn plain(body: &[Inst]) -> bool {
            body.iter().all(|inst| match inst {
                Inst::Loop { .. } | Inst::Break(_) | Inst::Continue(_) => false,
                Inst::If { then_body, else_body, .. } => plain(then_body) && plain(else_body),
                Inst::Block { body, .. } => plain(body),
                _ => true,
            })
        }
        let (start, end) = (self.int_constant(start)?, self.int_constant(end)?);
        (!self.masked && self.budget_uniform && plain(body)).then(|| (start, loop_trips(start, end)))
    }

    /// A loop every lane runs alike ([`Wide::uniform_trips`]): one scalar
    /// counter, the body unmasked (no blends), the budget tested in one
    /// lane.
    fn uniform_loop(&mut self, counter: ir::Var, start: i32, trips: i64, body: &[Inst]) {
        let k = self.b.declare_var(types::I32);
        let zero = self.b.ins().iconst(types::I32, 0);
        self.b.def_var(k, zero);
        let (header, body_b, exit) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(header);
        let (kv, left) = (self.b.use_var(k), self.b.use_var(self.budget));
        let in_range = self.b.ins().icmp_imm_s(IntCC::SignedLessThan, kv, trips);
        let left_one = self.b.ins().extractlane(left, 0);
        let funded = self.b.ins().icmp_imm_s(IntCC::SignedGreaterThan, left_one, 0);
        let more = self.b.ins().band(in_range, funded);
        self.b.ins().brif(more, body_b, &[], exit, &[]);

        self.b.switch_to_block(body_b);
        let one = self.splat_i(1);
        let spent = self.b.ins().isub(left, one);
        self.b.def_var(self.budget, spent);
        let i = self.b.ins().iadd_imm_s(kv, i64::from(start));
        let i = self.b.ins().splat(types::I32X4, i);
        self.b.def_var(self.vars[counter.0 as usize], i);
        self.body(body);
        let next = self.b.ins().iadd_imm_s(kv, 1);
        self.b.def_var(k, next);
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(exit);
    }

    /// A loop: all lanes iterate together while any has trips and budget
    /// left; a lane's `k`-th iteration runs under its mask.
    fn wide_loop(
        &mut self,
        inst: &Inst,
        label: Label,
        counter: ir::Var,
        start: ir::Value,
        end: ir::Value,
        body: &[Inst],
    ) {
        if let Some((first, trips)) = self.uniform_trips(start, end, body) {
            return self.uniform_loop(counter, first, trips, body);
        }
        self.budget_uniform = false;
        let (s, e) = (self.v(start), self.v(end));
        let trips = self.trips(s, e);
        let entry_masked = self.masked;
        let [k, running, finished, exited, continued] = [(); 5].map(|_| self.b.declare_var(types::I32X4));
        let zero = self.splat_i(0);
        let entry = self.b.use_var(self.exec);
        for (var, x) in [(k, zero), (running, entry), (finished, zero), (exited, zero), (continued, zero)] {
            self.b.def_var(var, x);
        }
        self.labels.insert(label, LabelMasks { exited, continued: Some(continued) });
        let (header, body_b, exit) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(header);
        let (kv, lanes, left) = (self.b.use_var(k), self.b.use_var(running), self.b.use_var(self.budget));
        let in_range = self.b.ins().icmp(IntCC::SignedLessThan, kv, trips);
        let zero = self.splat_i(0);
        let funded = self.b.ins().icmp(IntCC::SignedGreaterThan, left, zero);
        let more = self.b.ins().band(in_range, funded);
        let active = self.b.ins().band(lanes, more);
        let ended = self.b.ins().band_not(lanes, active);
        let so_far = self.b.use_var(finished);
        let so_far = self.b.ins().bor(so_far, ended);
        self.b.def_var(finished, so_far);
        let any = self.b.ins().vany_true(active);
        self.b.ins().brif(any, body_b, &[], exit, &[]);

        self.b.switch_to_block(body_b);
        // Active lanes are -1: adding spends one iteration of each.
        let spent = self.b.ins().iadd(left, active);
        self.b.def_var(self.budget, spent);
        let i = self.b.ins().iadd(s, kv);
        let var = self.vars[counter.0 as usize];
        let old = self.b.use_var(var);
        let i = self.blend(active, i, old);
        self.b.def_var(var, i);
        self.b.def_var(self.exec, active);
        self.b.def_var(continued, zero);
        self.masked = true;
        self.body(body);
        let (fell, again) = (self.b.use_var(self.exec), self.b.use_var(continued));
        let next_lanes = self.b.ins().bor(fell, again);
        self.b.def_var(running, next_lanes);
        let kv = self.b.use_var(k);
        let one = self.splat_i(1);
        let next = self.b.ins().iadd(kv, one);
        self.b.def_var(k, next);
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(exit);
        let (done, broke) = (self.b.use_var(finished), self.b.use_var(exited));
        let out = self.b.ins().bor(done, broke);
        self.b.def_var(self.exec, out);
        self.masked = entry_masked || escapes(std::slice::from_ref(inst));
    }

    /// A lane-by-lane lookup: `load(lane)` gives each lane's word.
    fn gather(&mut self, ty: Scalar, mut load: impl FnMut(&mut Self, usize) -> Value) -> Value {
        let first = load(self, 0);
        let mut x = self.b.ins().scalar_to_vector(types::I32X4, first);
        for l in 1..LANES {
            let w = load(self, l);
            x = self.b.ins().insertlane(x, w, l as u8);
        }
        self.words_as(ty, x)
    }

    /// Four words as a vector of `ty`.
    fn words_as(&mut self, ty: Scalar, x: Value) -> Value {
        match ty {
            Scalar::F32 => self.b.ins().bitcast(types::F32X4, MemFlagsData::new(), x),
            Scalar::I32 => x,
            Scalar::Bool => {
                let zero = self.splat_i(0);
                self.b.ins().icmp(IntCC::NotEqual, x, zero)
            }
        }
    }

    fn op(&mut self, op: &Op, ty: Scalar) -> Value {
        let readonly = MemFlagsData::trusted().with_readonly().with_can_move();
        match op {
            Op::F32(x) => {
                let s = self.b.ins().f32const(*x);
                self.b.ins().splat(types::F32X4, s)
            }
            Op::I32(x) => self.splat_i(i64::from(*x)),
            Op::Bool(x) => self.splat_i(if *x { -1 } else { 0 }),
            Op::Param(k) => self.record_word(self.records.args, *k, ty),
            Op::Global(k) => self.record_word(self.records.globals, *k, ty),
            Op::InstanceWord(k) => {
                let w = self.b.ins().load(types::I32, readonly, self.instance, (*k * 4) as i32);
                let x = self.b.ins().splat(types::I32X4, w);
                match ty {
                    Scalar::F32 => self.b.ins().bitcast(types::F32X4, MemFlagsData::new(), x),
                    Scalar::I32 => x,
                    Scalar::Bool => {
                        let zero = self.splat_i(0);
                        self.b.ins().icmp(IntCC::NotEqual, x, zero)
                    }
                }
            }
            Op::Get(var) => self.b.use_var(self.vars[var.0 as usize]),
            Op::Table { table, index } => {
                let index = self.v(*index);
                self.table_lookup(table, index, ty)
            }
            Op::Load { array, index } => {
                let index = self.v(*index);
                self.gather(ty, |g, l| {
                    let addr = g.array_word(*array, index, l);
                    g.b.ins().load(types::I32, MemFlagsData::trusted(), addr, 0)
                })
            }
            Op::Unary(UnOp::FToI, a) if self.x86 => {
                let a = self.v(*a);
                self.x86_float_to_int(a)
            }
            Op::Unary(u, a) => {
                let a = self.v(*a);
                let ins = self.b.ins();
                match u {
                    UnOp::FNeg => ins.fneg(a),
                    UnOp::FAbs => ins.fabs(a),
                    UnOp::Sqrt => ins.sqrt(a),
                    UnOp::Floor => ins.floor(a),
                    UnOp::Ceil => ins.ceil(a),
                    UnOp::Trunc => ins.trunc(a),
                    UnOp::INeg => ins.ineg(a),
                    UnOp::Not => ins.bnot(a),
                    UnOp::IToF => ins.fcvt_from_sint(types::F32X4, a),
                    // Saturating, NaN to 0: `ir::semantics::float_to_int`.
                    UnOp::FToI => ins.fcvt_to_sint_sat(types::I32X4, a),
                }
            }
            Op::Binary(bop, x, y) => {
                let (x, y) = (self.v(*x), self.v(*y));
                self.binary(*bop, x, y)
            }
            Op::Select { cond, then_value, else_value } => {
                let (c, a, z) = (self.v(*cond), self.v(*then_value), self.v(*else_value));
                self.blend(c, a, z)
            }
            Op::Call { native, args } => {
                let args: Vec<Value> = args.iter().map(|a| self.v(*a)).collect();
                let Some(f) = self.natives.get(native).copied() else {
                    // As the scalar code: NaN keeps an inconsistency visible.
                    let nan = self.b.ins().f32const(f32::NAN);
                    return self.b.ins().splat(types::F32X4, nan);
                };
                let nan = self.b.ins().f32const(f32::NAN);
                let mut x = self.b.ins().splat(types::F32X4, nan);
                for l in 0..LANES {
                    let lane_args: Vec<Value> = args.iter().map(|a| self.b.ins().extractlane(*a, l as u8)).collect();
                    let call = self.b.ins().call(f, &lane_args);
                    let r = self.b.inst_results(call)[0];
                    x = self.b.ins().insertlane(x, r, l as u8);
                }
                x
            }
        }
    }

    /// `ir::semantics::float_to_int` on x86-64 in five instructions where
    /// Cranelift's saturating conversion takes seven: `cvttps2dq` gives
    /// i32::MIN for NaN and for every lane out of range; a lane at or
    /// above 2^31 becomes i32::MAX (i32::MIN with every bit flipped), a NaN
    /// lane 0.
    fn x86_float_to_int(&mut self, a: Value) -> Value {
        let truncated = self.b.ins().x86_cvtt2dq(types::I32X4, a);
        let two_31 = self.b.ins().f32const(2147483648.0);
        let two_31 = self.b.ins().splat(types::F32X4, two_31);
        let above = self.b.ins().fcmp(FloatCC::LessThanOrEqual, two_31, a);
        let saturated = self.b.ins().bxor(truncated, above);
        let number = self.b.ins().fcmp(FloatCC::Ordered, a, a);
        self.b.ins().band(saturated, number)
    }

    /// Word `k` of every lane of a record, as a vector of type `ty`.
    fn record_word(&mut self, record: StackSlot, k: u32, ty: Scalar) -> Value {
        let at = (16 * k) as i32;
        match ty {
            Scalar::F32 => self.b.ins().stack_load(self.ptr, types::F32X4, record, at),
            Scalar::I32 => self.b.ins().stack_load(self.ptr, types::I32X4, record, at),
            Scalar::Bool => {
                let w = self.b.ins().stack_load(self.ptr, types::I32X4, record, at);
                let zero = self.splat_i(0);
                self.b.ins().icmp(IntCC::NotEqual, w, zero)
            }
        }
    }

    fn binary(&mut self, op: BinOp, x: Value, y: Value) -> Value {
        match op {
            BinOp::FAdd => self.b.ins().fadd(x, y),
            BinOp::FSub => self.b.ins().fsub(x, y),
            BinOp::FMul => self.b.ins().fmul(x, y),
            BinOp::FDiv => self.b.ins().fdiv(x, y),
            // `ir::semantics::fmin` and `fmax`: NaN gives the second operand.
            BinOp::FMin => {
                let c = self.b.ins().fcmp(FloatCC::LessThan, x, y);
                self.blend(c, x, y)
            }
            BinOp::FMax => {
                let c = self.b.ins().fcmp(FloatCC::LessThan, y, x);
                self.blend(c, x, y)
            }
            BinOp::IAdd => self.b.ins().iadd(x, y),
            BinOp::ISub => self.b.ins().isub(x, y),
            BinOp::IMul => self.b.ins().imul(x, y),
            BinOp::IDiv | BinOp::IRem => {
                let mut r = self.splat_i(0);
                for l in 0..LANES {
                    let (a, d) = (self.b.ins().extractlane(x, l as u8), self.b.ins().extractlane(y, l as u8));
                    let q = safe_div(self.b, op, a, d);
                    r = self.b.ins().insertlane(r, q, l as u8);
                }
                r
            }
            BinOp::IAnd | BinOp::And => self.b.ins().band(x, y),
            BinOp::Or => self.b.ins().bor(x, y),
            BinOp::FLt => self.b.ins().fcmp(FloatCC::LessThan, x, y),
            BinOp::FLe => self.b.ins().fcmp(FloatCC::LessThanOrEqual, x, y),
            BinOp::FEq => self.b.ins().fcmp(FloatCC::Equal, x, y),
            BinOp::ILt => self.b.ins().icmp(IntCC::SignedLessThan, x, y),
            BinOp::ILe => self.b.ins().icmp(IntCC::SignedLessThanOrEqual, x, y),
            BinOp::IEq | BinOp::BEq => self.b.ins().icmp(IntCC::Equal, x, y),
        }
    }
}

/// Whether `body` can send lanes to a label outside it (so lanes that
/// entered may not all come out of its end).
fn escapes(body: &[Inst]) -> bool {
    fn walk(body: &[Inst], inner: &mut Vec<Label>) -> bool {
        body.iter().any(|inst| match inst {
            Inst::Break(l) | Inst::Continue(l) => !inner.contains(l),
            Inst::If { then_body, else_body, .. } => walk(then_body, inner) || walk(else_body, inner),
            Inst::Block { label, body } | Inst::Loop { label, body, .. } => {
                inner.push(*label);
                let out = walk(body, inner);
                inner.pop();
                out
            }
            _ => false,
        })
    }
    walk(body, &mut Vec::new())
}
