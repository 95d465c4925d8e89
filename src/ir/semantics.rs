//! What the IR's total operations compute: the one definition that the
//! interpreter, the JIT and constant folding in lowering all follow.
//!
//! IR operations never trap and never hang (see the module invariants in
//! [`crate::ir`]). Where Rust or Cranelift would trap, wrap or leave a
//! result unspecified, the IR picks one answer, and it is written down here:
//! the interpreter and lowering's folding call these functions, and the JIT
//! emits code that computes the same (its comments point back here).

/// The most iterations one IR loop (`Inst::Loop`) runs, however
/// far apart its bounds are (2^16). The checker warns about constant bounds
/// beyond it.
pub const MAX_LOOP_ITERATIONS: i64 = 1 << 16;

/// The most loop iterations one call of a function runs over all its loops
/// together (2^18), so nested loops cannot multiply their caps; once it is
/// spent, every loop ends. With [`MAX_LOOP_ITERATIONS`], no IR function can
/// hang its host.
///
/// The trade-off: a budget this size leaves room for any loop a shading
/// call needs (64 octaves of noise, a 256 x 256 filter, a 512-step march),
/// while a runaway shader, spending all of it on every call, costs about
/// 0.3 ms per call, so a 64 x 64 preview stays within seconds (it was
/// 2^24, about 20 ms a call, and minutes for the same preview). The
/// checker warns where bounds that are not constants let a loop nest run
/// past it.
pub const MAX_CALL_ITERATIONS: i64 = 1 << 18;

/// [`BinOp::IDiv`](super::BinOp::IDiv): wrapping (`i32::MIN / -1` is
/// `i32::MIN`), and 0 for a zero divisor.
pub fn int_div(a: i32, b: i32) -> i32 {
    if b == 0 { 0 } else { a.wrapping_div(b) }
}

/// [`BinOp::IRem`](super::BinOp::IRem): wrapping (`i32::MIN % -1` is 0),
/// and 0 for a zero divisor.
pub fn int_rem(a: i32, b: i32) -> i32 {
    if b == 0 { 0 } else { a.wrapping_rem(b) }
}

/// [`BinOp::FMin`](super::BinOp::FMin): `a < b ? a : b`, so a NaN in
/// either operand gives `b`.
pub fn fmin(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// [`BinOp::FMax`](super::BinOp::FMax): `a > b ? a : b`, so a NaN in
/// either operand gives `b`.
pub fn fmax(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// [`UnOp::FToI`](super::UnOp::FToI): truncation toward zero, saturating
/// at `i32::MIN` and `i32::MAX`; NaN gives 0 (Cranelift's
/// `fcvt_to_sint_sat`, and Rust's `as`).
pub fn float_to_int(x: f32) -> i32 {
    x as i32
}

/// The element an array index reads or writes ([`Op::Load`](super::Op::Load),
/// [`Inst::Store`](super::Inst::Store)): the index clamped into `0..len`.
/// Arrays have at least one element, which the verifier checks.
pub fn clamp_index(index: i32, len: usize) -> usize {
    (index.max(0) as usize).min(len.saturating_sub(1))
}

/// The word an [`Op::Table`](super::Op::Table) lookup reads: the index
/// masked to the table's length, a power of two (which the verifier
/// checks), so negative and large indices wrap around the table.
pub fn table_index(index: i32, len: usize) -> usize {
    index as u32 as usize & (len - 1)
}

/// How many times a loop from `start` to `end` runs before the call's
/// budget is considered: `end - start` (computed without overflow), at
/// least 0 and at most [`MAX_LOOP_ITERATIONS`].
pub fn loop_trips(start: i32, end: i32) -> i64 {
    (i64::from(end) - i64::from(start)).clamp(0, MAX_LOOP_ITERATIONS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_edge_cases_have_one_answer() {
        assert_eq!((int_div(7, 0), int_rem(7, 0)), (0, 0));
        assert_eq!((int_div(i32::MIN, -1), int_rem(i32::MIN, -1)), (i32::MIN, 0));
        assert_eq!((int_div(-7, 2), int_rem(-7, 2)), (-3, -1));
        assert_eq!([float_to_int(f32::NAN), float_to_int(3e9), float_to_int(-3e9)], [0, i32::MAX, i32::MIN]);
        assert_eq!(float_to_int(-2.7), -2);
        assert!(fmin(f32::NAN, 1.0) == 1.0 && fmin(1.0, f32::NAN).is_nan());
        assert!(fmax(f32::NAN, 1.0) == 1.0 && fmax(1.0, f32::NAN).is_nan());
        assert_eq!([clamp_index(-5, 4), clamp_index(2, 4), clamp_index(9, 4)], [0, 2, 3]);
        assert_eq!([table_index(-1, 256), table_index(256, 256), table_index(300, 256)], [255, 0, 44]);
        assert_eq!([loop_trips(3, 1), loop_trips(i32::MIN, i32::MAX)], [0, MAX_LOOP_ITERATIONS]);
    }
}
