//! Batch entry points: one native call runs a compiled function over N
//! points, the loop inside the generated code.
//!
//! A batch entry is a small function of its own around the per-point entry
//! ([`EntryFn`]): for each point it gathers the words the function reads
//! (the globals words its IR reads, every argument word) from the caller's
//! columns into a record on its stack, calls the point entry, and scatters
//! the result words to the output columns. A column is a base pointer and
//! a byte stride, so one loop serves structure-of-arrays input, a field of
//! an array of structs, and one value broadcast to every point (stride 0).
//! It is compiled when a host first asks for a function's batch form, in a
//! module of its own, so programs that are never called in batches (the
//! renderer's) compile nothing more. This is the seam where a SIMD back end
//! would run several points per iteration.

use super::{EntryFn, native_isa};
use crate::globals::GLOBAL_WORDS;
use cranelift_codegen::Context;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::{
    AbiParam, Block, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Type, UserFuncName, Value, types,
};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{FuncId, Linkage, Module};

/// Where one word of every point lives: point `i`'s word is the `u32` at
/// `base + i * stride` bytes. Laid out as the generated code reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct ColumnPtr {
    pub base: *const u32,
    pub stride: isize,
}

/// The native signature of a batch entry: the globals table has
/// [`GLOBAL_WORDS`] columns (only those of words the function reads are
/// looked at), the argument and output tables one per word.
pub type BatchFn = unsafe extern "C" fn(
    globals: *const ColumnPtr,
    args: *const ColumnPtr,
    out: *const ColumnPtr,
    instance: *const u32,
    points: usize,
);

/// The compiled batch entry of one function; its code is freed on drop.
pub struct BatchCode {
    module: Option<JITModule>,
    entry: BatchFn,
    /// Data the code reads by address (tables it copied), freed with it.
    tables: Vec<Box<[u32]>>,
}

// SAFETY: as for `Jit`: after `finalize_definitions` the code is immutable
// and only read; the module is touched again only by `Drop`.
unsafe impl Send for BatchCode {}
// SAFETY: as above.
unsafe impl Sync for BatchCode {}

impl Drop for BatchCode {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: `entry` is handed out only as a copy whose use is tied
            // to `&self` (`BatchCode::entry`), so nothing calls it after this.
            unsafe { module.free_memory() };
        }
    }
}

impl BatchCode {
    /// Defines the batch entry `id` of `module` from `ctx` (a function of
    /// [`BatchFn`]'s signature) and finalizes the module; `what` names the
    /// entry in errors.
    pub(super) fn define(
        mut module: JITModule,
        id: FuncId,
        ctx: &mut Context,
        what: &str,
    ) -> Result<BatchCode, String> {
        module.define_function(id, ctx).map_err(|e| format!("cannot compile {what}: {e:?}"))?;
        module.finalize_definitions().map_err(|e| e.to_string())?;
        let code = module.get_finalized_function(id);
        // SAFETY: the caller defined it with the platform C ABI taking five
        // pointer-sized values and returning nothing: exactly `BatchFn`.
        let entry = unsafe { std::mem::transmute::<*const u8, BatchFn>(code) };
        Ok(BatchCode { module: Some(module), entry, tables: Vec::new() })
    }

    /// The code, keeping `tables` alive as long as it is: it reads them.
    pub(super) fn keeping(mut self, tables: Vec<Box<[u32]>>) -> BatchCode {
        self.tables = tables;
        self
    }

    pub fn entry(&self) -> BatchFn {
        self.entry
    }
}

/// What the batch entry of one function gathers and scatters.
pub struct BatchShape<'a> {
    /// The globals words the function reads, each below [`GLOBAL_WORDS`].
    pub globals_read: &'a [u32],
    pub arg_words: usize,
    pub result_words: usize,
}

/// Compiles the batch entry around `point`.
///
/// # Safety
/// `point` must be a live entry of compiled code that reads at most the
/// globals words in `shape.globals_read`, `shape.arg_words` argument words
/// and writes `shape.result_words` result words, and stays alive as long as
/// the returned code is called.
pub unsafe fn compile_batch(point: EntryFn, shape: &BatchShape) -> Result<BatchCode, String> {
    assert!(shape.globals_read.iter().all(|&w| w < GLOBAL_WORDS), "globals words out of range");
    let isa = native_isa(false)?;
    let mut module = JITModule::new(JITBuilder::with_isa(isa.clone(), cranelift_module::default_libcall_names()));
    let ptr = module.target_config().pointer_type();
    let mut point_sig = module.make_signature();
    point_sig.params.extend([AbiParam::new(ptr); 4]);
    let mut sig = module.make_signature();
    sig.params.extend([AbiParam::new(ptr); 5]);
    let id = module.declare_function("tsl_batch", Linkage::Local, &sig).map_err(|e| e.to_string())?;

    let mut ctx = Context::new();
    ctx.func = cranelift_codegen::ir::Function::with_name_signature(UserFuncName::user(0, 0), sig);
    let mut fctx = FunctionBuilderContext::new();
    let mut b = FunctionBuilder::new(&mut ctx.func, &mut fctx);
    let word_slot = |b: &mut FunctionBuilder, words: usize| {
        b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 4 * words.max(1) as u32, 2))
    };
    let (globals_slot, args_slot, out_slot) = (
        word_slot(&mut b, GLOBAL_WORDS as usize),
        word_slot(&mut b, shape.arg_words),
        word_slot(&mut b, shape.result_words),
    );
    let point_sig = b.import_signature(point_sig);

    let l = PointLoop::begin(&mut b, ptr, |_, _| {});
    let i = l.i;
    for &w in shape.globals_read {
        let from = column_word(&mut b, ptr, l.globals, w as usize, i);
        let x = b.ins().load(types::I32, MemFlagsData::trusted(), from, 0);
        b.ins().stack_store(ptr, x, globals_slot, 4 * w as i32);
    }
    for k in 0..shape.arg_words {
        let from = column_word(&mut b, ptr, l.args, k, i);
        let x = b.ins().load(types::I32, MemFlagsData::trusted(), from, 0);
        b.ins().stack_store(ptr, x, args_slot, 4 * k as i32);
    }
    let globals_record = b.ins().stack_addr(ptr, globals_slot, 0);
    let args_record = b.ins().stack_addr(ptr, args_slot, 0);
    let out_record = b.ins().stack_addr(ptr, out_slot, 0);
    let callee = b.ins().iconst(ptr, point as usize as i64);
    b.ins().call_indirect(point_sig, callee, &[globals_record, args_record, out_record, l.instance]);
    for k in 0..shape.result_words {
        let x = b.ins().stack_load(ptr, types::I32, out_slot, 4 * k as i32);
        let to = column_word(&mut b, ptr, l.out, k, i);
        b.ins().store(MemFlagsData::trusted(), x, to, 0);
    }
    l.end(&mut b, 1);
    b.finalize(module.target_config());

    BatchCode::define(module, id, &mut ctx, "a batch entry")
}

/// The loop of a batch entry over its points, some at a time: the
/// entry's parameters and the first point of this iteration, `i`.
pub(super) struct PointLoop {
    pub globals: Value,
    pub args: Value,
    pub out: Value,
    pub instance: Value,
    pub points: Value,
    pub i: Value,
    header: Block,
    exit: Block,
}

impl PointLoop {
    /// Emits the entry, `prologue` (given the entry's parameters: globals,
    /// args, out, instance, points) and the loop's test (`i < points`);
    /// leaves `b` in the loop's body.
    pub(super) fn begin(
        b: &mut FunctionBuilder,
        ptr: Type,
        prologue: impl FnOnce(&mut FunctionBuilder, [Value; 5]),
    ) -> PointLoop {
        let (entry, header, body, exit) = (b.create_block(), b.create_block(), b.create_block(), b.create_block());
        b.append_block_params_for_function_params(entry);
        b.append_block_param(header, ptr);
        b.switch_to_block(entry);
        let params: [Value; 5] = b.block_params(entry).try_into().expect("five parameters");
        let [globals, args, out, instance, points] = params;
        prologue(b, params);
        let zero = b.ins().iconst(ptr, 0);
        b.ins().jump(header, &[zero.into()]);
        b.switch_to_block(header);
        let i = b.block_params(header)[0];
        let done = b.ins().icmp(IntCC::UnsignedGreaterThanOrEqual, i, points);
        b.ins().brif(done, exit, &[], body, &[]);
        b.switch_to_block(body);
        PointLoop { globals, args, out, instance, points, i, header, exit }
    }

    /// Ends the body (`i += step`, back to the test) and returns at the
    /// exit; every block is sealed.
    pub(super) fn end(self, b: &mut FunctionBuilder, step: i64) {
        let next = b.ins().iadd_imm_u(self.i, step);
        b.ins().jump(self.header, &[next.into()]);
        b.switch_to_block(self.exit);
        b.ins().return_(&[]);
        b.seal_all_blocks();
    }
}

/// The address of `point`'s word in column `k` of the column table
/// `columns` (a [`ColumnPtr`] per word).
pub(super) fn column_word(b: &mut FunctionBuilder, ptr: Type, columns: Value, k: usize, point: Value) -> Value {
    let table = MemFlagsData::trusted().with_readonly();
    let at = (k * std::mem::size_of::<ColumnPtr>()) as i32;
    let base = b.ins().load(ptr, table, columns, at);
    let stride = b.ins().load(ptr, table, columns, at + std::mem::size_of::<*const u32>() as i32);
    let offset = b.ins().imul(point, stride);
    b.ins().iadd(base, offset)
}
