//! Table lookups of the four-lane batch entry: small tables by byte
//! shuffles in registers (small whole floats, such as noise's gradients,
//! one shuffle each), larger ones gathered lane by lane, and a table
//! looked up at i and i + 1 (noise's permutation) gathered in pairs.

use super::{LANES, Wide};
use crate::ir::{self, BinOp, Inst, Op, Scalar};
use cranelift_codegen::ir::{Endianness, InstBuilder, MemFlagsData, StackSlotData, StackSlotKind, Value, types};
use cranelift_codegen::isa::TargetIsa;

/// The largest table looked up by byte shuffles rather than loads
/// ([`Wide::shuffled_table`]): one shuffle covers 16 bytes.
const SHUFFLED_TABLE_WORDS: usize = 16;

/// Whether a byte shuffle is one instruction on `isa`: x86-64 without
/// SSSE3 would call a helper that the JIT module does not provide.
pub(super) fn has_byte_shuffles(isa: &dyn TargetIsa) -> bool {
    isa.name() != "x64" || isa.isa_flags().iter().any(|f| f.name == "has_ssse3" && f.as_bool() == Some(true))
}

impl Wide<'_, '_> {
    /// `table[index]` (the lookup masks the index): a byte shuffle for a
    /// small table, else a gather lane by lane.
    pub(super) fn table_lookup(&mut self, table: &[u32], index: Value, ty: Scalar) -> Value {
        if self.shuffles(table) {
            if ty == Scalar::F32
                && let Some(bytes) = small_whole_floats(table)
            {
                return self.shuffled_small_whole_floats(&bytes, index);
            }
            let words = self.shuffled_table(table, index);
            return self.words_as(ty, words);
        }
        // A load per lane (an address mode each: base + index * 4).
        // Each lane's index is masked as a 32-bit integer: x86-64
        // clears the upper half there, so widening it to an address
        // costs no instruction.
        let readonly = MemFlagsData::trusted().with_readonly().with_can_move();
        let base = self.b.ins().iconst(self.ptr, table.as_ptr() as i64);
        let indices = self.table_indices(index, table.len());
        self.gather(ty, |g, l| {
            let offset = g.b.ins().ishl_imm_u(indices[l], 2);
            let addr = g.b.ins().iadd(base, offset);
            g.b.ins().load(types::I32, readonly, addr, 0)
        })
    }

    /// Defines `first` and its partner ([`Wide::pair_lookups`]), looked up
    /// at `index` and the next word by one paired gather.
    pub(super) fn paired_lookup(&mut self, first: ir::Value, table: &[u32], index: ir::Value) {
        let second = self.paired[&first];
        let index = self.v(index);
        let [x, y] = self.paired_gather(table, index);
        for (value, words) in [(first, x), (second, y)] {
            let ty = self.func.value_type(value);
            self.values[value.0 as usize] = Some(self.words_as(ty, words));
        }
    }

    /// Whether lookups in `table` are byte shuffles ([`Wide::shuffled_table`]).
    fn shuffles(&self, table: &[u32]) -> bool {
        self.byte_shuffles && table.len() <= SHUFFLED_TABLE_WORDS
    }

    /// Pairs each gathered lookup of `body` (at its top level) with a later
    /// one of the next word of the same table, when the index's definitions
    /// show it is the next ([`Wide::is_successor`]): noise's permutation
    /// is looked up at i and i + 1 on every axis. A pair is gathered
    /// together, a 64-bit load a lane ([`Wide::paired_gather`]).
    pub(super) fn pair_lookups(&mut self, body: &[Inst]) {
        // How far after a lookup its partner is looked for (noise's are
        // at most 8 lookups apart).
        const WINDOW: usize = 16;
        if !self.byte_shuffles {
            return;
        }
        let lookups: Vec<(ir::Value, &'static [u32], ir::Value)> = body
            .iter()
            .filter_map(|inst| match inst {
                Inst::Def(v, Op::Table { table, index }) if !self.shuffles(table) && table.len() >= 2 => {
                    Some((*v, *table, *index))
                }
                _ => None,
            })
            .collect();
        let mut taken = vec![false; lookups.len()];
        for i in 0..lookups.len() {
            let (first, table, index) = lookups[i];
            if taken[i] {
                continue;
            }
            let partner = (i + 1..lookups.len()).take(WINDOW).find(|&j| {
                !taken[j] && std::ptr::eq(lookups[j].1, table) && self.is_successor(index, lookups[j].2, table.len(), 4)
            });
            if let Some(j) = partner {
                taken[i] = true;
                taken[j] = true;
                self.paired.insert(first, lookups[j].0);
            }
        }
    }

    /// Whether `b` is `a + 1` modulo `len` (a power of two) by the form of
    /// their definitions, looking `depth` definitions deep: `b = a + 1`,
    /// `b = x & m` with `x` the successor and `m`'s low bits all ones, or
    /// `a = p + q` and `b = p + r` with `r` the successor of `q`.
    fn is_successor(&self, a: ir::Value, b: ir::Value, len: usize, depth: u32) -> bool {
        if depth == 0 {
            return false;
        }
        let constant = |v: ir::Value| self.int_constant(v);
        let keeps_index = |m: ir::Value| constant(m).is_some_and(|c| (c as u32 as usize) & (len - 1) == len - 1);
        match self.defs.get(&b) {
            Some(Op::Binary(BinOp::IAnd, x, y)) => {
                (keeps_index(*y) && self.is_successor(a, *x, len, depth - 1))
                    || (keeps_index(*x) && self.is_successor(a, *y, len, depth - 1))
            }
            Some(Op::Binary(BinOp::IAdd, x, y)) => {
                if (*x == a && constant(*y) == Some(1)) || (*y == a && constant(*x) == Some(1)) {
                    return true;
                }
                let Some(Op::Binary(BinOp::IAdd, p, q)) = self.defs.get(&a) else { return false };
                [(p, q), (q, p)].into_iter().any(|(same, before)| {
                    [(x, y), (y, x)]
                        .into_iter()
                        .any(|(shared, after)| same == shared && self.is_successor(*before, *after, len, depth - 1))
                })
            }
            _ => false,
        }
    }

    /// Each lane's `index & (len - 1)` as an address-sized integer. Lane by
    /// lane, an extraction and a 32-bit `and` (x86-64 clears the upper half
    /// there, so widening costs no instruction); for a table of 256 words
    /// (noise's permutation) on x86-64 the index is its low byte: the
    /// vector is stored once and each lane's first byte loaded
    /// zero-extended, one instruction a lane where the other way is two.
    fn table_indices(&mut self, index: Value, len: usize) -> [Value; LANES] {
        // x86-64 only: its vectors' lanes are stored in order, little-endian.
        if len == 256 && self.x86_shuffles {
            let slot = *self.indices.get_or_insert_with(|| {
                self.b.create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, 16, 4))
            });
            self.b.ins().stack_store(self.ptr, index, slot, 0);
            let at = self.b.ins().stack_addr(self.ptr, slot, 0);
            return std::array::from_fn(|l| self.b.ins().uload8(self.ptr, MemFlagsData::trusted(), at, 4 * l as i32));
        }
        std::array::from_fn(|l| {
            let i = self.b.ins().extractlane(index, l as u8);
            let i = self.b.ins().band_imm_u(i, len as i64 - 1);
            self.b.ins().uextend(self.ptr, i)
        })
    }

    /// The address of `table` with its first word again after its last,
    /// copied once per table and kept with the code.
    fn padded_table(&mut self, table: &[u32]) -> i64 {
        let k = *self.padded_index.entry(table.as_ptr()).or_insert_with(|| {
            let mut words = table.to_vec();
            words.push(table[0]);
            self.padded.push(words.into_boxed_slice());
            self.padded.len() - 1
        });
        self.padded[k].as_ptr() as i64
    }

    /// `table[index & (len - 1)]` and `table[(index + 1) & (len - 1)]`:
    /// one 64-bit load a lane from the padded copy of the table, the pairs
    /// then split into the first words and the second words (two `shufps`),
    /// where two gathers load and insert a word at a time.
    fn paired_gather(&mut self, table: &[u32], index: Value) -> [Value; 2] {
        let base = self.padded_table(table);
        let base = self.b.ins().iconst(self.ptr, base);
        let readonly = MemFlagsData::new().with_notrap().with_readonly().with_can_move();
        let little = MemFlagsData::new().with_endianness(Endianness::Little);
        let indices = self.table_indices(index, table.len());
        let halves: [Value; 2] = [0, 1].map(|h| {
            let mut pairs = None;
            for l in [2 * h, 2 * h + 1] {
                let offset = self.b.ins().ishl_imm_u(indices[l], 2);
                let addr = self.b.ins().iadd(base, offset);
                let pair = self.b.ins().load(types::I64, readonly, addr, 0);
                pairs = Some(match pairs {
                    None => self.b.ins().scalar_to_vector(types::I64X2, pair),
                    Some(v) => self.b.ins().insertlane(v, pair, 1),
                });
            }
            let pairs = pairs.expect("two lanes");
            self.b.ins().bitcast(types::I8X16, little, pairs)
        });
        // Words 0..8 of the two halves: lane l's pair is words 2l and 2l + 1.
        [0, 1].map(|second| {
            let bytes: Vec<u8> = (0..4).flat_map(|l| (0..4).map(move |k| (4 * (2 * l + second) + k) as u8)).collect();
            let mask = self.b.func.dfg.immediates.push(bytes.into());
            let words = self.b.ins().shuffle(halves[0], halves[1], mask);
            self.b.ins().bitcast(types::I32X4, little, words)
        })
    }

    /// `table[index & (len - 1)]` for a table of at most
    /// [`SHUFFLED_TABLE_WORDS`] words, in registers: byte `k` of the four
    /// words is one byte shuffle of the table's bytes `k` (a 16-byte
    /// constant) by the index, where a gather loads lane by lane. Noise's
    /// gradient tables (`runtime::GRAD3_WORDS`, ...) are 16 and 8 words
    /// with two bytes that are not zero.
    fn shuffled_table(&mut self, table: &[u32], index: Value) -> Value {
        let mask = self.splat_i(table.len() as i64 - 1);
        let index = self.b.ins().band(index, mask);
        let little = MemFlagsData::new().with_endianness(Endianness::Little);
        let mut words: Option<Value> = None;
        for k in 0..4u32 {
            let mut plane = [0u8; 16];
            for (byte, w) in plane.iter_mut().zip(table) {
                *byte = (w >> (8 * k)) as u8;
            }
            if plane == [0; 16] {
                continue;
            }
            // Byte k of each lane is the index into the plane; the other
            // bytes are out of range (0x80), which shuffles in zeros.
            let shifted = if k == 0 { index } else { self.b.ins().ishl_imm_u(index, i64::from(8 * k)) };
            let out_of_range = self.splat_i(i64::from((0x8080_8080u32 & !(0xff << (8 * k))) as i32));
            let selectors = self.b.ins().bor(shifted, out_of_range);
            let selectors = self.b.ins().bitcast(types::I8X16, little, selectors);
            let bytes = self.byte_shuffle(plane, selectors);
            let bytes = self.b.ins().bitcast(types::I32X4, little, bytes);
            words = Some(match words {
                Some(w) => self.b.ins().bor(w, bytes),
                None => bytes,
            });
        }
        words.unwrap_or_else(|| self.splat_i(0))
    }

    /// The bytes of the constant `plane` that `selectors` (an `i8x16`)
    /// pick, zero where a selector's top bit is set.
    fn byte_shuffle(&mut self, plane: [u8; 16], selectors: Value) -> Value {
        let constant = self.b.func.dfg.constants.insert(plane.to_vec().into());
        let plane = self.b.ins().vconst(types::I8X16, constant);
        // `x86_pshufb` zeroes where a selector's top bit is set, as
        // ours are; `swizzle` adds a saturating add to give any index
        // above 15 that meaning (x86-64's lowering of it).
        if self.x86_shuffles {
            self.b.ins().x86_pshufb(plane, selectors)
        } else {
            self.b.ins().swizzle(plane, selectors)
        }
    }

    /// `table[index & (len - 1)]` for a table of small whole floats
    /// ([`small_whole_floats`]: `bytes` are its values as bytes): one
    /// byte shuffle puts each lane's value in its top byte, an arithmetic
    /// shift extends its sign and a conversion makes it the float, exactly
    /// (noise's gradients: one shuffle where [`Wide::shuffled_table`] needs
    /// two, and no merging of bytes).
    fn shuffled_small_whole_floats(&mut self, bytes: &[u8], index: Value) -> Value {
        // The index's low bits (`index & (len - 1)`, len a power of two)
        // in the top byte by two shifts, the selector that counts (no mask,
        // no register for one); the three low bytes are zero and pick the
        // plane's byte 0, which the shift below drops.
        let bits = bytes.len().trailing_zeros();
        let selectors = if bits == 0 {
            self.splat_i(0)
        } else {
            let high = self.b.ins().ishl_imm_u(index, i64::from(32 - bits));
            self.b.ins().ushr_imm_u(high, i64::from(8 - bits))
        };
        let little = MemFlagsData::new().with_endianness(Endianness::Little);
        let selectors = self.b.ins().bitcast(types::I8X16, little, selectors);
        let mut plane = [0u8; 16];
        plane[..bytes.len()].copy_from_slice(bytes);
        let top = self.byte_shuffle(plane, selectors);
        let top = self.b.ins().bitcast(types::I32X4, little, top);
        let ints = self.b.ins().sshr_imm_u(top, 24);
        self.b.ins().fcvt_from_sint(types::F32X4, ints)
    }
}

/// The values of a table whose every word is a whole float from -128 to
/// 127 (`0.0`, not `-0.0`), as bytes; `None` for any other table.
fn small_whole_floats(table: &[u32]) -> Option<Vec<u8>> {
    table
        .iter()
        .map(|&w| {
            let k = i8::try_from(f32::from_bits(w) as i32).ok()?;
            (f32::from(k).to_bits() == w).then_some(k as u8)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Noise's 1D and 3D gradient tables are small whole floats (one
    /// shuffle a lookup), its 2D diagonals (1/sqrt 2) are not; nor is a
    /// table with a value past a byte, a negative zero or a NaN.
    #[test]
    fn small_whole_floats_are_the_tables_a_byte_holds_exactly() {
        use crate::runtime::{GRAD1_WORDS, GRAD2_WORDS, GRAD3_WORDS};
        for table in [&GRAD1_WORDS[..], &GRAD3_WORDS[0], &GRAD3_WORDS[1], &GRAD3_WORDS[2]] {
            let bytes = small_whole_floats(table).expect("whole floats");
            for (b, w) in bytes.iter().zip(table) {
                assert_eq!(f32::from(*b as i8).to_bits(), *w);
            }
        }
        assert_eq!(small_whole_floats(&GRAD2_WORDS[0]), None);
        let words = |xs: &[f32]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        assert_eq!(small_whole_floats(&words(&[-128.0, 127.0, 0.0, -1.0])), Some(vec![0x80, 0x7f, 0, 0xff]));
        for bad in [0.5, 128.0, -129.0, -0.0, f32::NAN, f32::INFINITY] {
            assert_eq!(small_whole_floats(&words(&[1.0, bad])), None, "{bad}");
        }
    }

    /// The flag is read by its Cranelift name: a misspelt name would
    /// quietly gather every table (`tests/batch.rs` checks the bits).
    #[test]
    fn small_tables_are_shuffled_where_the_machine_can() {
        let isa = crate::jit::native_isa(false).unwrap();
        #[cfg(target_arch = "x86_64")]
        assert_eq!(has_byte_shuffles(&*isa), std::is_x86_feature_detected!("ssse3"));
        #[cfg(not(target_arch = "x86_64"))]
        assert!(has_byte_shuffles(&*isa));
    }
}
