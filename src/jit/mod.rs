//! Cranelift code generation: one native `extern "C"` function per IR
//! function, `fn(globals: *const ShadingGlobals, args: *const u32, out: *mut u32,
//! instance: *const u32)`.
//!
//! All `unsafe` of the crate lives here. The generated code reads only the
//! globals record, the argument words, the instance parameter block (a
//! run-time-bound instance's values; unread by other code) and its own
//! stack slots, and writes
//! only the result words: IR operations are total (clamped indices, guarded
//! integer division, saturating conversions, bounded loops), so the code
//! cannot trap or hang. Its memory is freed when the [`Jit`] is dropped.
//! Those answers are `ir::semantics`'s, emitted as Cranelift code; this
//! module depends on `ir`, the runtime natives and textures only, never on
//! the front end.

mod batch;
mod simd;

pub use batch::{BatchCode, BatchShape, ColumnPtr, compile_batch};
pub use simd::compile_batch_simd;

use crate::ir::semantics::{MAX_CALL_ITERATIONS, MAX_LOOP_ITERATIONS};
use crate::ir::{self, BinOp, Inst, Label, Op, Scalar, UnOp};
use crate::runtime::natives;
use cranelift_codegen::control::ControlPlane;
use cranelift_codegen::ir::UserFuncName;
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::{
    AbiParam, Block, ExtFuncData, ExternalName, FuncRef, InstBuilder, MemFlagsData, Signature, StackSlotData,
    StackSlotKind, Type, UserExternalName, types,
};
use cranelift_codegen::isa::{TargetFrontendConfig, TargetIsa};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_codegen::{Context, ir::Value as ClValue};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext, Variable};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module, ModuleReloc};
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The native signature of every entry point.
pub type EntryFn = unsafe extern "C" fn(globals: *const u32, args: *const u32, out: *mut u32, instance: *const u32);

/// Compiled code for a whole IR module.
pub struct Jit {
    module: Option<JITModule>,
    functions: HashMap<String, EntryFn>,
    /// The samplers the code points to, kept alive as long as it.
    _samplers: Vec<std::sync::Arc<crate::texture::Sampler>>,
    /// Cranelift IR text per function, when asked for (`tslc emit --emit clif`).
    pub clif: Vec<(String, String)>,
}

// SAFETY: after `finalize_definitions` the code is immutable and the entry
// points are plain function pointers; the module itself is touched again only
// by `Drop`, which has `&mut self`.
unsafe impl Send for Jit {}
// SAFETY: as above; calling the functions from many threads at once is safe
// because they only read their inputs and write their own outputs.
unsafe impl Sync for Jit {}

impl Drop for Jit {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: the `Jit` owns the only copies of the function pointers
            // (`function` hands out copies whose use is tied to `&self`), so
            // nothing can call into the code after this.
            unsafe { module.free_memory() };
        }
    }
}

impl Jit {
    /// The compiled entry point of an IR function.
    pub fn function(&self, name: &str) -> Option<EntryFn> {
        self.functions.get(name).copied()
    }
}

/// Options for code generation.
#[derive(Debug, Clone, Default)]
pub struct JitOptions {
    /// Keep the Cranelift IR text of each function in [`Jit::clif`].
    pub keep_clif: bool,
    /// Give functions beyond [`LARGE_FUNCTION`] instructions the optimiser
    /// and the backtracking allocator too: about twice the compile time of
    /// a deep texture tree, for code that runs it about 1.3x faster (fewer
    /// spills). Worth it when the code will run for seconds (long renders);
    /// the same operations either way, so results are the same bits.
    pub optimize_large: bool,
}

/// IR functions up to this many instructions get Cranelift's optimiser and
/// its backtracking register allocator (the best code); larger ones, which
/// deep texture trees produce, the single-pass allocator without the
/// optimiser, whose cost grows gently with size. Our IR is value-numbered
/// and folded already, so the optimiser adds little to either.
const LARGE_FUNCTION: usize = 600;

/// A native ISA with our settings; `large` picks the fast-compiling ones.
fn native_isa(large: bool) -> Result<std::sync::Arc<dyn TargetIsa>, String> {
    let mut flags = settings::builder();
    // Cranelift's IR verifier checks our translation; debug builds (the
    // tests) keep it, release builds skip its share of compile time.
    let verify = if cfg!(debug_assertions) { "true" } else { "false" };
    let (opt, regalloc) = if large { ("none", "single_pass") } else { ("speed", "backtracking") };
    for (k, v) in [
        ("use_colocated_libcalls", "false"),
        ("is_pic", "false"),
        ("opt_level", opt),
        ("regalloc_algorithm", regalloc),
        ("enable_verifier", verify),
    ] {
        flags.set(k, v).map_err(|e| e.to_string())?;
    }
    cranelift_native::builder()
        .map_err(|e| format!("this machine is not supported by Cranelift: {e}"))?
        .finish(settings::Flags::new(flags))
        .map_err(|e| e.to_string())
}

/// Compiles every function of an IR module.
pub fn compile(module: &ir::Module, options: &JitOptions) -> Result<Jit, String> {
    let isa = native_isa(false)?;
    let large_isa = native_isa(!options.optimize_large)?;
    let mut builder = JITBuilder::with_isa(isa.clone(), cranelift_module::default_libcall_names());
    for n in natives() {
        builder.symbol(n.name, n.ptr);
    }
    builder.symbol(TEXTURE_SYMBOL, crate::texture::tsl_texture as *const u8);
    builder.symbol(SPECTRUM_TEXTURE_SYMBOL, crate::texture::tsl_texture_spectrum as *const u8);
    let mut jit = JITModule::new(builder);
    let ptr = jit.target_config().pointer_type();

    // Natives: f32 x arity -> f32.
    let mut natives_declared = Vec::new();
    for n in natives() {
        let mut sig = jit.make_signature();
        sig.params.extend((0..n.arity).map(|_| AbiParam::new(types::F32)));
        sig.returns.push(AbiParam::new(types::F32));
        let id = jit.declare_function(n.name, Linkage::Import, &sig).map_err(|e| e.to_string())?;
        natives_declared.push((n.name, id, sig));
    }

    // tsl_texture(sampler, s, t, dsdx, dtdx, dsdy, dtdy, out).
    let mut texture_sig = jit.make_signature();
    texture_sig.params.push(AbiParam::new(ptr));
    texture_sig.params.extend((0..6).map(|_| AbiParam::new(types::F32)));
    texture_sig.params.push(AbiParam::new(ptr));
    let texture_id = jit.declare_function(TEXTURE_SYMBOL, Linkage::Import, &texture_sig).map_err(|e| e.to_string())?;
    // tsl_texture_spectrum(sampler, s, t, dsdx, dtdx, dsdy, dtdy, t0, t1, t2, t3, out).
    let mut spectrum_sig = jit.make_signature();
    spectrum_sig.params.push(AbiParam::new(ptr));
    spectrum_sig.params.extend((0..10).map(|_| AbiParam::new(types::F32)));
    spectrum_sig.params.push(AbiParam::new(ptr));
    let spectrum_id =
        jit.declare_function(SPECTRUM_TEXTURE_SYMBOL, Linkage::Import, &spectrum_sig).map_err(|e| e.to_string())?;

    let mut entry_sig = jit.make_signature();
    entry_sig.params.extend([AbiParam::new(ptr), AbiParam::new(ptr), AbiParam::new(ptr), AbiParam::new(ptr)]);
    let mut ids = Vec::new();
    for (k, f) in module.functions.iter().enumerate() {
        // Unique by position; the IR name after it (dots and other
        // characters as `_`) names the code in profilers (`perf`).
        let readable: String = f.name.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
        let symbol = format!("tsl_entry_{k}_{readable}");
        let id = jit.declare_function(&symbol, Linkage::Local, &entry_sig).map_err(|e| e.to_string())?;
        ids.push(id);
    }

    // Every core translates and compiles functions (each is independent),
    // then the code is defined in the module here.
    let imports = Imports {
        natives: natives_declared,
        texture: [(texture_id, texture_sig), (spectrum_id, spectrum_sig)],
        entry_sig,
        target: jit.target_config(),
        ptr,
    };
    let compiled = compile_parallel([&*isa, &*large_isa], &imports, &ids, &module.functions, options.keep_clif)?;
    let mut clif = Vec::new();
    for ((id, code), f) in ids.iter().zip(compiled).zip(&module.functions) {
        jit.define_function_bytes(*id, code.alignment, &code.bytes, &code.relocs).map_err(|e| e.to_string())?;
        if let Some(text) = code.clif {
            clif.push((f.name.clone(), text));
        }
    }
    jit.finalize_definitions().map_err(|e| e.to_string())?;
    let mut functions = HashMap::new();
    for (f, id) in module.functions.iter().zip(&ids) {
        let code = jit.get_finalized_function(*id);
        // SAFETY: the function was defined with `entry_sig`, the platform C
        // ABI taking four pointers and returning nothing: exactly `EntryFn`.
        let entry = unsafe { std::mem::transmute::<*const u8, EntryFn>(code) };
        functions.insert(f.name.clone(), entry);
    }
    let mut samplers = Vec::new();
    for f in &module.functions {
        ir::for_each_inst(&f.body, &mut |inst| {
            if let Inst::Texture { sampler, .. } = inst {
                samplers.push(sampler.0.clone());
            }
        });
    }
    Ok(Jit { module: Some(jit), functions, clif, _samplers: samplers })
}

/// The symbol of [`crate::texture::tsl_texture`] in generated code.
const TEXTURE_SYMBOL: &str = "tsl_texture";
/// The symbol of [`crate::texture::tsl_texture_spectrum`].
const SPECTRUM_TEXTURE_SYMBOL: &str = "tsl_texture_spectrum";

/// Machine code of one function, ready to define in the module.
struct Code {
    bytes: Vec<u8>,
    alignment: u64,
    relocs: Vec<ModuleReloc>,
    /// Its Cranelift IR text, when asked for.
    clif: Option<String>,
}

/// The module's declarations a worker needs to translate a function on its
/// own thread (the module itself stays with the caller).
struct Imports {
    natives: Vec<(&'static str, FuncId, Signature)>,
    /// `tsl_texture` and `tsl_texture_spectrum`.
    texture: [(FuncId, Signature); 2],
    entry_sig: Signature,
    target: TargetFrontendConfig,
    ptr: Type,
}

impl Imports {
    /// The IR function `k` in Cranelift IR.
    fn translate(
        &self,
        k: usize,
        f: &ir::Function,
        fctx: &mut FunctionBuilderContext,
    ) -> cranelift_codegen::ir::Function {
        let mut func = cranelift_codegen::ir::Function::with_name_signature(
            UserFuncName::user(0, k as u32),
            self.entry_sig.clone(),
        );
        let natives = self.natives.iter().map(|(name, id, sig)| (*name, import(&mut func, *id, sig))).collect();
        let texture = self.texture.each_ref().map(|(id, sig)| import(&mut func, *id, sig));
        let mut b = FunctionBuilder::new(&mut func, fctx);
        let mut g = Gen::new(&mut b, f, natives, texture, self.ptr);
        g.entry();
        g.body(&f.body);
        g.finish();
        b.seal_all_blocks();
        b.finalize(self.target);
        func
    }
}

/// Imports the module's function `id`, declared with `Linkage::Import`,
/// into `func`: what `Module::declare_func_in_func` does, without the module
/// (which cannot be shared between threads).
fn import(func: &mut cranelift_codegen::ir::Function, id: FuncId, sig: &Signature) -> FuncRef {
    let signature = func.import_signature(sig.clone());
    let name = func.declare_imported_user_function(UserExternalName { namespace: 0, index: id.as_u32() });
    func.import_function(ExtFuncData { name: ExternalName::user(name), signature, colocated: false, patchable: false })
}

/// Translates and compiles functions on all available cores.
fn compile_parallel(
    isas: [&dyn TargetIsa; 2],
    imports: &Imports,
    ids: &[FuncId],
    ir_functions: &[ir::Function],
    keep_clif: bool,
) -> Result<Vec<Code>, String> {
    let sizes: Vec<usize> = ir_functions.iter().map(|f| ir::count_insts(&f.body)).collect();
    // Biggest first from one shared queue: the threads finish together even
    // when a few functions (a tree's `sample`) dwarf the rest.
    let mut order: Vec<usize> = (0..ir_functions.len()).collect();
    order.sort_by_key(|&k| std::cmp::Reverse(sizes[k]));
    let next = AtomicUsize::new(0);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(ir_functions.len().max(1));
    // Each thread reuses one Cranelift context (its register allocator's
    // buffers above all), as Cranelift advises.
    let compile_one = |k: usize, fctx: &mut FunctionBuilderContext, ctx: &mut Context| -> Result<Code, String> {
        let name = &ir_functions[k].name;
        let func = imports.translate(k, &ir_functions[k], fctx);
        let clif = keep_clif.then(|| func.display().to_string());
        let isa = isas[usize::from(sizes[k] > LARGE_FUNCTION)];
        ctx.clear();
        ctx.func = func;
        ctx.compile(isa, &mut ControlPlane::default())
            .map_err(|e| format!("cannot compile `{name}`: {:?}", e.inner))?;
        let compiled = ctx.compiled_code().ok_or_else(|| format!("no code for `{name}`"))?;
        let alignment = u64::from(compiled.buffer.alignment)
            .max(u64::from(isa.function_alignment().minimum))
            .max(isa.symbol_alignment());
        let bytes = compiled.code_buffer().to_vec();
        let relocs =
            compiled.buffer.relocs().iter().map(|r| ModuleReloc::from_mach_reloc(r, &ctx.func, ids[k])).collect();
        Ok(Code { bytes, alignment, relocs, clif })
    };
    let worker = || {
        let (mut fctx, mut ctx) = (FunctionBuilderContext::new(), Context::new());
        let mut done = Vec::new();
        while let Some(&k) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
            done.push((k, compile_one(k, &mut fctx, &mut ctx)));
        }
        done
    };
    let mut results: Vec<Option<Result<Code, String>>> = (0..ir_functions.len()).map(|_| None).collect();
    std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads).map(|_| scope.spawn(worker)).collect();
        for h in handles {
            let done = h.join().map_err(|_| "a code generation thread panicked".to_string())?;
            for (k, code) in done {
                results[k] = Some(code);
            }
        }
        Ok::<(), String>(())
    })?;
    results.into_iter().map(|r| r.unwrap_or_else(|| Err("a function was not compiled".into()))).collect()
}

fn cl_type(s: Scalar) -> Type {
    match s {
        Scalar::F32 => types::F32,
        Scalar::I32 => types::I32,
        Scalar::Bool => types::I8,
    }
}

/// Translates one IR function.
struct Gen<'a, 'b> {
    b: &'a mut FunctionBuilder<'b>,
    func: &'a ir::Function,
    values: Vec<Option<ClValue>>,
    vars: Vec<Variable>,
    /// Loop iterations the call may still run, over all loops (i64).
    budget: Option<Variable>,
    arrays: Vec<cranelift_codegen::ir::StackSlot>,
    /// Exit block and, for loops, the continue block of each label.
    labels: HashMap<Label, (Block, Option<Block>)>,
    natives: HashMap<&'static str, FuncRef>,
    /// `tsl_texture` and `tsl_texture_spectrum`.
    texture: [FuncRef; 2],
    ptr: Type,
    globals: ClValue,
    args: ClValue,
    out: ClValue,
    /// The instance parameter block (`Op::InstanceWord`).
    instance: ClValue,
}

impl<'a, 'b> Gen<'a, 'b> {
    fn new(
        b: &'a mut FunctionBuilder<'b>,
        func: &'a ir::Function,
        natives: HashMap<&'static str, FuncRef>,
        texture: [FuncRef; 2],
        ptr: Type,
    ) -> Self {
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let params = b.block_params(entry).to_vec();
        Gen {
            b,
            func,
            values: vec![None; func.values.len()],
            vars: Vec::new(),
            budget: None,
            arrays: Vec::new(),
            labels: HashMap::new(),
            natives,
            texture,
            ptr,
            globals: params[0],
            args: params[1],
            out: params[2],
            instance: params[3],
        }
    }

    fn entry(&mut self) {
        let budget = self.b.declare_var(types::I64);
        let max = self.b.ins().iconst(types::I64, MAX_CALL_ITERATIONS);
        self.b.def_var(budget, max);
        self.budget = Some(budget);
        for ty in &self.func.vars {
            let var = self.b.declare_var(cl_type(*ty));
            // Every variable starts defined (at zero), as in the interpreter.
            let zero = self.zero(*ty);
            self.b.def_var(var, zero);
            self.vars.push(var);
        }
        for (ty, len) in &self.func.arrays {
            let _ = ty;
            let slot =
                self.b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 4 * len.max(&1), 2));
            self.arrays.push(slot);
        }
    }

    fn finish(&mut self) {
        self.b.ins().return_(&[]);
    }

    fn zero(&mut self, ty: Scalar) -> ClValue {
        match ty {
            Scalar::F32 => self.b.ins().f32const(0.0),
            Scalar::I32 => self.b.ins().iconst(types::I32, 0),
            Scalar::Bool => self.b.ins().iconst(types::I8, 0),
        }
    }

    fn v(&self, v: ir::Value) -> ClValue {
        // Lowering defines every value before its uses (dominance invariant).
        self.values[v.0 as usize].expect("IR value used before its definition")
    }

    /// After a jump, code that follows in the same IR body is unreachable;
    /// it goes into a fresh block with no predecessors.
    fn start_dead_block(&mut self) {
        let dead = self.b.create_block();
        self.b.switch_to_block(dead);
    }

    fn body(&mut self, body: &[Inst]) {
        for inst in body {
            self.inst(inst);
        }
    }

    fn word_addr(&mut self, base: ClValue, index: ClValue) -> ClValue {
        let wide = self.b.ins().uextend(self.ptr, index);
        let offset = self.b.ins().ishl_imm_u(wide, 2);
        self.b.ins().iadd(base, offset)
    }

    /// Clamps an index into `0..len`, as `ir::semantics::clamp_index`.
    fn clamp_index(&mut self, index: ClValue, len: u32) -> ClValue {
        let zero = self.b.ins().iconst(types::I32, 0);
        let last = self.b.ins().iconst(types::I32, i64::from(len.max(1) - 1));
        let lo = self.b.ins().smax(index, zero);
        self.b.ins().smin(lo, last)
    }

    fn inst(&mut self, inst: &Inst) {
        let trusted = MemFlagsData::trusted();
        match inst {
            Inst::Def(v, op) => {
                let ty = self.func.value_type(*v);
                let x = self.op(op, ty);
                self.values[v.0 as usize] = Some(x);
            }
            Inst::Set(var, v) => {
                let x = self.v(*v);
                self.b.def_var(self.vars[var.0 as usize], x);
            }
            Inst::Store { array, index, value } => {
                let len = self.func.arrays[array.0 as usize].1;
                let i = self.v(*index);
                let i = self.clamp_index(i, len);
                let base = self.b.ins().stack_addr(self.ptr, self.arrays[array.0 as usize], 0);
                let addr = self.word_addr(base, i);
                let x = self.v(*value);
                let x =
                    if self.func.value_type(*value) == Scalar::Bool { self.b.ins().uextend(types::I32, x) } else { x };
                self.b.ins().store(trusted, x, addr, 0);
            }
            Inst::Texture { sampler, coords, out } => {
                // The sampler is owned by this function's IR and kept alive
                // by the `Jit`, so its address is a constant of the code.
                let native = self.texture[usize::from(sampler.0.spectral.is_some())];
                let sampler = self.b.ins().iconst(self.ptr, std::sync::Arc::as_ptr(&sampler.0) as i64);
                let dest = self.b.ins().stack_addr(self.ptr, self.arrays[out.0 as usize], 0);
                let mut args = vec![sampler];
                args.extend(coords.iter().map(|c| self.v(*c)));
                args.push(dest);
                self.b.ins().call(native, &args);
            }
            Inst::Output(k, v) => {
                let x = self.v(*v);
                let x = if self.func.value_type(*v) == Scalar::Bool { self.b.ins().uextend(types::I32, x) } else { x };
                self.b.ins().store(trusted, x, self.out, (*k * 4) as i32);
            }
            Inst::If { cond, then_body, else_body } => {
                let c = self.v(*cond);
                let (then_b, else_b, merge) = (self.b.create_block(), self.b.create_block(), self.b.create_block());
                self.b.ins().brif(c, then_b, &[], else_b, &[]);
                self.b.switch_to_block(then_b);
                self.body(then_body);
                self.b.ins().jump(merge, &[]);
                self.b.switch_to_block(else_b);
                self.body(else_body);
                self.b.ins().jump(merge, &[]);
                self.b.switch_to_block(merge);
            }
            Inst::Block { label, body } => {
                let exit = self.b.create_block();
                self.labels.insert(*label, (exit, None));
                self.body(body);
                self.b.ins().jump(exit, &[]);
                self.b.switch_to_block(exit);
            }
            Inst::Loop { label, counter, start, end, body } => {
                // Trip count, computed in 64 bits so no bound can overflow:
                // clamp(end - start, 0, MAX_LOOP_ITERATIONS), as
                // `ir::semantics::loop_trips`.
                let s = self.v(*start);
                let e = self.v(*end);
                let s64 = self.b.ins().sextend(types::I64, s);
                let e64 = self.b.ins().sextend(types::I64, e);
                let d = self.b.ins().isub(e64, s64);
                let zero = self.b.ins().iconst(types::I64, 0);
                let max = self.b.ins().iconst(types::I64, MAX_LOOP_ITERATIONS);
                let d = self.b.ins().smax(d, zero);
                let trips = self.b.ins().smin(d, max);
                let k = self.b.declare_var(types::I64);
                self.b.def_var(k, zero);
                let (header, body_b, latch, exit) =
                    (self.b.create_block(), self.b.create_block(), self.b.create_block(), self.b.create_block());
                self.b.ins().jump(header, &[]);
                self.b.switch_to_block(header);
                let kv = self.b.use_var(k);
                let in_range = self.b.ins().icmp(IntCC::SignedLessThan, kv, trips);
                // Every loop of the call draws on one budget, so nested
                // loops cannot multiply their caps.
                let budget = self.budget.expect("entry() declares the budget");
                let left = self.b.use_var(budget);
                let funded = self.b.ins().icmp_imm_s(IntCC::SignedGreaterThan, left, 0);
                let more = self.b.ins().band(in_range, funded);
                self.b.ins().brif(more, body_b, &[], exit, &[]);
                self.b.switch_to_block(body_b);
                let left = self.b.use_var(budget);
                let spent = self.b.ins().iadd_imm_s(left, -1);
                self.b.def_var(budget, spent);
                let kv = self.b.use_var(k);
                let i64v = self.b.ins().iadd(s64, kv);
                let i = self.b.ins().ireduce(types::I32, i64v);
                self.b.def_var(self.vars[counter.0 as usize], i);
                self.labels.insert(*label, (exit, Some(latch)));
                self.body(body);
                self.b.ins().jump(latch, &[]);
                self.b.switch_to_block(latch);
                let kv = self.b.use_var(k);
                let next = self.b.ins().iadd_imm_s(kv, 1);
                self.b.def_var(k, next);
                self.b.ins().jump(header, &[]);
                self.b.switch_to_block(exit);
            }
            Inst::Break(l) => {
                if let Some((exit, _)) = self.labels.get(l).copied() {
                    self.b.ins().jump(exit, &[]);
                    self.start_dead_block();
                }
            }
            Inst::Continue(l) => {
                if let Some((_, Some(latch))) = self.labels.get(l).copied() {
                    self.b.ins().jump(latch, &[]);
                    self.start_dead_block();
                }
            }
        }
    }

    fn op(&mut self, op: &Op, ty: Scalar) -> ClValue {
        // The globals, arguments and tables do not change during a call, and
        // every address is in bounds: Cranelift may load them where they are
        // first used rather than at entry (fewer values live, fewer spills).
        let readonly = MemFlagsData::trusted().with_readonly().with_can_move();
        match op {
            Op::F32(x) => self.b.ins().f32const(*x),
            Op::I32(x) => self.b.ins().iconst(types::I32, i64::from(*x)),
            Op::Bool(x) => self.b.ins().iconst(types::I8, i64::from(*x)),
            Op::Param(k) => self.load_word(self.args, *k, ty, readonly),
            Op::Global(k) => self.load_word(self.globals, *k, ty, readonly),
            Op::InstanceWord(k) => self.load_word(self.instance, *k, ty, readonly),
            Op::Get(var) => self.b.use_var(self.vars[var.0 as usize]),
            Op::Table { table, index } => {
                // The table is a `'static` slice: its address is a constant.
                // The index is masked, as `ir::semantics::table_index`.
                let i = self.v(*index);
                let i = self.b.ins().band_imm_u(i, table.len() as i64 - 1);
                let base = self.b.ins().iconst(self.ptr, table.as_ptr() as i64);
                let addr = self.word_addr(base, i);
                let word = if ty == Scalar::F32 { types::F32 } else { types::I32 };
                self.b.ins().load(word, readonly, addr, 0)
            }
            Op::Load { array, index } => {
                let len = self.func.arrays[array.0 as usize].1;
                let i = self.v(*index);
                let i = self.clamp_index(i, len);
                let base = self.b.ins().stack_addr(self.ptr, self.arrays[array.0 as usize], 0);
                let addr = self.word_addr(base, i);
                let word = if ty == Scalar::F32 { types::F32 } else { types::I32 };
                let x = self.b.ins().load(word, MemFlagsData::trusted(), addr, 0);
                if ty == Scalar::Bool { self.b.ins().ireduce(types::I8, x) } else { x }
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
                    UnOp::Not => ins.bxor_imm_u(a, 1),
                    UnOp::IToF => ins.fcvt_from_sint(types::F32, a),
                    // Saturating, NaN to 0: `ir::semantics::float_to_int`.
                    UnOp::FToI => ins.fcvt_to_sint_sat(types::I32, a),
                }
            }
            Op::Binary(bop, x, y) => {
                let (x, y) = (self.v(*x), self.v(*y));
                self.binary(*bop, x, y)
            }
            Op::Select { cond, then_value, else_value } => {
                let (c, a, z) = (self.v(*cond), self.v(*then_value), self.v(*else_value));
                self.b.ins().select(c, a, z)
            }
            Op::Call { native, args } => {
                let args: Vec<ClValue> = args.iter().map(|a| self.v(*a)).collect();
                match self.natives.get(native).copied() {
                    Some(f) => {
                        let call = self.b.ins().call(f, &args);
                        self.b.inst_results(call)[0]
                    }
                    // Lowering only names natives that exist; NaN keeps an
                    // inconsistency visible rather than crashing.
                    None => self.b.ins().f32const(f32::NAN),
                }
            }
        }
    }

    fn load_word(&mut self, base: ClValue, k: u32, ty: Scalar, flags: MemFlagsData) -> ClValue {
        let offset = (k * 4) as i32;
        match ty {
            Scalar::F32 => self.b.ins().load(types::F32, flags, base, offset),
            Scalar::I32 => self.b.ins().load(types::I32, flags, base, offset),
            Scalar::Bool => {
                let w = self.b.ins().load(types::I32, flags, base, offset);
                let nz = self.b.ins().icmp_imm_s(IntCC::NotEqual, w, 0);
                // icmp gives an i8 0/1, the IR's bool.
                nz
            }
        }
    }

    fn binary(&mut self, op: BinOp, x: ClValue, y: ClValue) -> ClValue {
        let ins = self.b.ins();
        match op {
            BinOp::FAdd => ins.fadd(x, y),
            BinOp::FSub => ins.fsub(x, y),
            BinOp::FMul => ins.fmul(x, y),
            BinOp::FDiv => ins.fdiv(x, y),
            // `ir::semantics::fmin` and `fmax`: a compare and a select, so
            // NaN gives the second operand (Cranelift's fmin would give NaN).
            BinOp::FMin => {
                let c = ins.fcmp(FloatCC::LessThan, x, y);
                self.b.ins().select(c, x, y)
            }
            // `y < x` rather than `x > y` (the same answer, NaN included):
            // the form Cranelift lowers to one `maxss`, as `fmin` to `minss`.
            BinOp::FMax => {
                let c = ins.fcmp(FloatCC::LessThan, y, x);
                self.b.ins().select(c, x, y)
            }
            BinOp::IAdd => ins.iadd(x, y),
            BinOp::ISub => ins.isub(x, y),
            BinOp::IMul => ins.imul(x, y),
            BinOp::IDiv | BinOp::IRem => safe_div(self.b, op, x, y),
            BinOp::IAnd => ins.band(x, y),
            BinOp::FLt => ins.fcmp(FloatCC::LessThan, x, y),
            BinOp::FLe => ins.fcmp(FloatCC::LessThanOrEqual, x, y),
            BinOp::FEq => ins.fcmp(FloatCC::Equal, x, y),
            BinOp::ILt => ins.icmp(IntCC::SignedLessThan, x, y),
            BinOp::ILe => ins.icmp(IntCC::SignedLessThanOrEqual, x, y),
            BinOp::IEq | BinOp::BEq => ins.icmp(IntCC::Equal, x, y),
            BinOp::And => ins.band(x, y),
            BinOp::Or => ins.bor(x, y),
        }
    }
}

/// Integer division without traps, as `ir::semantics::int_div` and
/// `int_rem`: a zero divisor gives 0, and `MIN / -1` wraps.
fn safe_div(b: &mut FunctionBuilder, op: BinOp, x: ClValue, y: ClValue) -> ClValue {
    let zero = b.ins().iconst(types::I32, 0);
    let one = b.ins().iconst(types::I32, 1);
    let is_zero = b.ins().icmp_imm_s(IntCC::Equal, y, 0);
    let is_minus_one = b.ins().icmp_imm_s(IntCC::Equal, y, -1);
    let special = b.ins().bor(is_zero, is_minus_one);
    let divisor = b.ins().select(special, one, y);
    let (plain, by_minus_one) =
        if op == BinOp::IDiv { (b.ins().sdiv(x, divisor), b.ins().ineg(x)) } else { (b.ins().srem(x, divisor), zero) };
    let r = b.ins().select(is_minus_one, by_minus_one, plain);
    b.ins().select(is_zero, zero, r)
}
