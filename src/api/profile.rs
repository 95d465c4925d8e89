//! Profiling a compiled function: how much work one call does, counted by
//! the reference interpreter (as OSL's shader profiling counts what a
//! shading call ran). Counts, not timings, so they are the same on every
//! machine and comparable between revisions of a shader.

use super::Function;
use crate::globals::ShadingGlobals;
use crate::interp::{self, OpCounts};

impl Function {
    /// Calls the function through the interpreter, as
    /// [`Function::call_words`] with [`Backend::Interpreter`](super::Backend)
    /// would (the same results in `out`), and returns what the call
    /// evaluated: IR operations, native calls, texture lookups and noise
    /// evaluations. Short `args` or `out` are an error, as for `call_words`.
    ///
    /// ```
    /// let src = "float grain(float s) { return fbm(P * s, 4) + noise(P); }";
    /// let p = tsl::Compiler::new().source("g.tsl", src).compile()?;
    /// let grain = p.function("grain").expect("defined");
    /// let g = tsl::ShadingGlobals { p: [0.3, 0.2, 0.1], ..Default::default() };
    /// let mut out = [0u32; 1];
    /// let counts = grain.count_ops(&g, &[4.0f32.to_bits()], &mut out)?;
    /// assert_eq!(counts.noise, 5.0, "four octaves and one noise");
    /// assert!(counts.operations > 0);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn count_ops(&self, g: &ShadingGlobals, args: &[u32], out: &mut [u32]) -> Result<OpCounts, String> {
        let (params, results, _) = self.words;
        if args.len() < params || out.len() < results {
            return Err(self.words_error());
        }
        let instance = self.instance_block()?;
        Ok(interp::run_counting(self.ir(), &g.words(), args, instance, out))
    }
}

#[cfg(test)]
mod tests {
    use crate::{Compiler, ShadingGlobals};

    fn counts(src: &str, name: &str, args: &[f32]) -> crate::OpCounts {
        let p = Compiler::new().source("t.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"));
        let f = p.function(name).unwrap_or_else(|| panic!("no {name}"));
        let g = ShadingGlobals { p: [0.3, 0.7, 0.1], pl: [0.3, 0.7, 0.1], ..Default::default() };
        let args: Vec<u32> = args.iter().map(|x| x.to_bits()).collect();
        let mut out = vec![0u32; f.result_types().len()];
        let counts = f.count_ops(&g, &args, &mut out).unwrap();
        // The same results as an ordinary interpreted call.
        let mut plain = vec![0u32; out.len()];
        f.call_words(crate::Backend::Interpreter, &g, &args, &mut plain).unwrap();
        assert_eq!(out, plain);
        counts
    }

    /// Noise is counted once per evaluation whether lowering expanded it
    /// inline (the first four sites of a function) or called the native.
    #[test]
    fn noise_is_counted_once_per_evaluation_inline_or_native() {
        let one = counts("float f() { return noise(P); }", "f", &[]);
        assert_eq!(one.noise, 1.0);
        assert_eq!(one.native_calls, 0, "the first site is expanded inline");
        let six =
            "float f() { return noise(P) + noise(P * 2) + noise(P * 3) + noise(P * 4) + noise(P * 5) + noise(P * 6); }";
        let six = counts(six, "f", &[]);
        assert_eq!(six.noise, 6.0);
        assert_eq!(six.native_calls, 2, "sites past the fourth call the native");
        assert!(six.operations > one.operations);
        let octaves = counts("float f(float n) { return fbm(P, int(n)); }", "f", &[3.0]);
        assert_eq!(octaves.noise, 3.0, "a loop's noise once per trip");
    }

    #[test]
    fn operations_follow_the_branch_taken_and_add_up() {
        let src = "float f(float x) { if (x > 0) { return sin(x) * cos(x) + sqrt(x); } return x; }";
        let (taken, skipped) = (counts(src, "f", &[0.5]), counts(src, "f", &[-0.5]));
        assert!(taken.operations > skipped.operations, "{taken:?} vs {skipped:?}");
        assert_eq!(skipped.noise + taken.noise, 0.0);
        let mut sum = taken;
        sum += skipped;
        assert_eq!(sum.operations, taken.operations + skipped.operations);
        assert_eq!(sum.native_calls, taken.native_calls + skipped.native_calls);
    }

    #[test]
    fn short_slices_are_an_error() {
        let p = Compiler::new().source("t.tsl", "float f(float x) { return x; }").compile().unwrap();
        let f = p.function("f").unwrap();
        let err = f.count_ops(&ShadingGlobals::default(), &[], &mut [0u32; 1]).unwrap_err();
        assert!(err.contains("takes 1 argument words"), "{err}");
    }
}
