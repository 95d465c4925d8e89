//! The fuzzing campaign (not in CI: `scripts/fuzz.sh`, see docs/performance.md, "Scale and fuzzing").
//!
//! Feeds generated inputs to the front end and, when one checks clean, to
//! lowering and both back ends, which must agree on every entry point:
//! arbitrary bytes, token soups, and mutations of the repository's own
//! `.tsl` files (byte flips, deleted, duplicated and swapped ranges,
//! splices of two files). Random *well-typed* programs are the other half
//! of the campaign: `tests/random_programs.rs` with `PROPTEST_CASES`.
//!
//! Findings: a panic (caught, the input saved), a disagreement between the
//! back ends (saved), and a hang (an input still running after
//! `TSL_FUZZ_TIMEOUT` seconds: saved, then the process aborts so the
//! campaign fails). A crash kills the process and so fails the run; the
//! input being run is in `fuzz-failures/current-<worker>.tsl`.
//!
//! `TSL_FUZZ_INPUTS` (default 10,000) inputs in all, `TSL_FUZZ_SEED`
//! (default 1), `TSL_FUZZ_JOBS` workers (default 2).

mod common;

use common::{Rng, TOKENS, args, close, shading_point};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};
use tsl::{Backend, Compiler, LoadOptions};

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// Every `.tsl` file under `dir`.
fn tsl_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            tsl_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "tsl") {
            out.push(p);
        }
    }
}

fn corpus() -> Vec<Vec<u8>> {
    let mut files = Vec::new();
    for dir in ["examples", "stdlib", "tests/check/ok", "tests/check/err"] {
        tsl_files(Path::new(dir), &mut files);
    }
    files.sort();
    files.iter().filter_map(|p| std::fs::read(p).ok()).collect()
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Bytes,
    Soup,
    Mutant,
}

const KINDS: [Kind; 4] = [Kind::Bytes, Kind::Soup, Kind::Mutant, Kind::Mutant];

fn below(rng: &mut Rng, n: usize) -> usize {
    (rng.next() % n.max(1) as u64) as usize
}

/// A random range of `text`, at most `max` bytes long.
fn range(rng: &mut Rng, len: usize, max: usize) -> (usize, usize) {
    let start = below(rng, len + 1);
    let end = (start + below(rng, max + 1)).min(len);
    (start, end)
}

/// The bytes a flipped byte becomes.
const FLIPS: &[u8] = b" {}();,.+-*/=<>!?:\"0123456789abcxyz_\n";

fn mutate(rng: &mut Rng, corpus: &[Vec<u8>]) -> Vec<u8> {
    let mut text = corpus[below(rng, corpus.len())].clone();
    for _ in 0..1 + below(rng, 4) {
        let len = text.len();
        match rng.next() % 6 {
            0 if len > 0 => {
                let i = below(rng, len);
                text[i] = FLIPS[below(rng, FLIPS.len())];
            }
            1 => {
                let (s, e) = range(rng, len, 40);
                text.drain(s..e);
            }
            2 => {
                let (s, e) = range(rng, len, 40);
                let piece = text[s..e].to_vec();
                let at = below(rng, text.len() + 1);
                text.splice(at..at, piece);
            }
            3 => {
                let (s1, e1) = range(rng, len, 20);
                let (s2, e2) = range(rng, len, 20);
                if e1 <= s2 {
                    let (a, b) = (text[s1..e1].to_vec(), text[s2..e2].to_vec());
                    text.splice(s2..e2, a);
                    text.splice(s1..e1, b);
                }
            }
            4 => {
                let other = &corpus[below(rng, corpus.len())];
                let (s, e) = range(rng, other.len(), 400);
                let at = below(rng, len + 1);
                text.splice(at..at, other[s..e].to_vec());
            }
            _ => {
                let at = below(rng, len + 1);
                let token = TOKENS[below(rng, TOKENS.len())];
                text.splice(at..at, format!(" {token} ").into_bytes());
            }
        }
    }
    text
}

fn generate(kind: Kind, rng: &mut Rng, corpus: &[Vec<u8>]) -> Vec<u8> {
    match kind {
        Kind::Bytes => (0..below(rng, 300)).map(|_| rng.next() as u8).collect(),
        Kind::Soup => {
            let n = below(rng, 150);
            let words: Vec<&str> = (0..n).map(|_| TOKENS[below(rng, TOKENS.len())]).collect();
            words.join(" ").into_bytes()
        }
        Kind::Mutant => mutate(rng, corpus),
    }
}

/// What one input did.
enum Outcome {
    Rejected,
    /// Checked clean and compiled: this many entries compared.
    Compared(usize),
    Disagreement(String),
}

/// The front end on `src`; when it checks clean, lowering and both back
/// ends on every entry the program defines, at a few shading points.
fn run(src: &str, seed: u64) -> Outcome {
    let checked = tsl::check_source("fuzz.tsl", src, &LoadOptions::default());
    if !checked.is_ok() {
        let _ = checked.render_diagnostics();
        return Outcome::Rejected;
    }
    let Ok(program) = Compiler::new().eager(true).source("fuzz.tsl", src).compile() else {
        return Outcome::Rejected;
    };
    let mut rng = Rng(seed | 1);
    let mut compared = 0;
    for entry in program.functions() {
        let Some(f) = program.function(entry.name()) else { continue };
        let results = f.result_types();
        let (mut jit, mut interp) = (vec![0u32; results.len()], vec![0u32; results.len()]);
        for point in 0..3 {
            let g = if point == 0 { tsl::ShadingGlobals::default() } else { shading_point(&mut rng) };
            let a = args(&mut rng, entry.params(), program.color_model());
            let ran = f.call_words(Backend::Jit, &g, &a, &mut jit).and(f.call_words(
                Backend::Interpreter,
                &g,
                &a,
                &mut interp,
            ));
            if ran.is_err() {
                continue;
            }
            for (k, ty) in results.iter().enumerate() {
                if !close(jit[k], interp[k], *ty) {
                    return Outcome::Disagreement(format!(
                        "{} word {k}: jit {:?} vs interpreter {:?} at {g:?} with {a:?}",
                        entry.name(),
                        f32::from_bits(jit[k]),
                        f32::from_bits(interp[k])
                    ));
                }
            }
        }
        compared += 1;
    }
    Outcome::Compared(compared)
}

#[derive(Default)]
struct Tally {
    per_kind: [u64; 3],
    compiled: u64,
    entries: u64,
    panics: u64,
    disagreements: u64,
}

fn save(dir: &Path, name: &str, text: &[u8]) -> PathBuf {
    let _ = std::fs::create_dir_all(dir);
    let path = dir.join(name);
    let _ = std::fs::write(&path, text);
    path
}

#[test]
#[ignore = "the fuzzing campaign: scripts/fuzz.sh"]
fn fuzz() {
    let inputs = env_or("TSL_FUZZ_INPUTS", 10_000);
    let seed = env_or("TSL_FUZZ_SEED", 1);
    let jobs = env_or("TSL_FUZZ_JOBS", 2).clamp(1, 64) as usize;
    let timeout = Duration::from_secs(env_or("TSL_FUZZ_TIMEOUT", 20));
    let failures = PathBuf::from("fuzz-failures");
    let corpus = corpus();
    assert!(!corpus.is_empty(), "run from the repository root: no .tsl files found");
    // Panics in the compiler are findings, reported with their input; the
    // default hook would also print each one's message.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if std::env::var_os("TSL_FUZZ_VERBOSE").is_some() {
            default_hook(info);
        }
    }));
    let next = AtomicU64::new(0);
    let tally = Mutex::new(Tally::default());
    // The time each worker started its current input (ms since `epoch`, 0: idle).
    let epoch = Instant::now();
    let started: Vec<AtomicU64> = (0..jobs).map(|_| AtomicU64::new(0)).collect();
    let done_workers = AtomicUsize::new(0);
    let report_every = (inputs / 20).max(1);
    std::thread::scope(|scope| {
        for worker in 0..jobs {
            let (next, tally, started, corpus, failures, done_workers) =
                (&next, &tally, &started, &corpus, &failures, &done_workers);
            scope.spawn(move || {
                // Counted even if this worker panics, so the watchdog ends.
                struct Done<'a>(&'a AtomicUsize);
                impl Drop for Done<'_> {
                    fn drop(&mut self) {
                        self.0.fetch_add(1, Ordering::SeqCst);
                    }
                }
                let _done = Done(done_workers);
                loop {
                    let n = next.fetch_add(1, Ordering::Relaxed);
                    if n >= inputs {
                        break;
                    }
                    let input_seed =
                        (seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ n.wrapping_mul(0xD1B5_4A32_D192_ED03)) | 1;
                    let mut rng = Rng(input_seed);
                    let kind = KINDS[below(&mut rng, KINDS.len())];
                    let Ok(bytes) = catch_unwind(AssertUnwindSafe(|| generate(kind, &mut rng, corpus))) else {
                        panic!("the fuzzer's own generator panicked on input {n}");
                    };
                    let src = String::from_utf8_lossy(&bytes).into_owned();
                    save(failures, &format!("current-{worker}.tsl"), src.as_bytes());
                    started[worker].store(epoch.elapsed().as_millis() as u64 + 1, Ordering::SeqCst);
                    let outcome = catch_unwind(AssertUnwindSafe(|| run(&src, input_seed)));
                    started[worker].store(0, Ordering::SeqCst);
                    let mut t = tally.lock().unwrap();
                    t.per_kind[kind as usize] += 1;
                    match outcome {
                        Ok(Outcome::Rejected) => {}
                        Ok(Outcome::Compared(k)) => {
                            t.compiled += 1;
                            t.entries += k as u64;
                        }
                        Ok(Outcome::Disagreement(why)) => {
                            t.disagreements += 1;
                            let path = save(failures, &format!("disagree-{n}.tsl"), src.as_bytes());
                            eprintln!("disagreement on input {n} ({kind:?}), saved to {}: {why}", path.display());
                        }
                        Err(_) => {
                            t.panics += 1;
                            let path = save(failures, &format!("panic-{n}.tsl"), src.as_bytes());
                            eprintln!("panic on input {n} ({kind:?}), saved to {}", path.display());
                        }
                    }
                    if (n + 1) % report_every == 0 {
                        eprintln!("{} / {inputs} inputs, {:.0} s", n + 1, epoch.elapsed().as_secs_f64());
                    }
                }
                let _ = std::fs::remove_file(failures.join(format!("current-{worker}.tsl")));
            });
        }
        // The watchdog: an input running longer than `timeout` is a hang.
        scope.spawn(|| {
            while done_workers.load(Ordering::SeqCst) < jobs {
                std::thread::sleep(Duration::from_millis(200));
                let now = epoch.elapsed().as_millis() as u64;
                for (worker, s) in started.iter().enumerate() {
                    let s = s.load(Ordering::SeqCst);
                    if s != 0 && now.saturating_sub(s) > timeout.as_millis() as u64 {
                        let from = failures.join(format!("current-{worker}.tsl"));
                        let to = failures.join(format!("hang-{}.tsl", std::process::id()));
                        let _ = std::fs::copy(&from, &to);
                        eprintln!("hang: an input ran over {timeout:?}, saved to {}", to.display());
                        std::process::abort();
                    }
                }
            }
        });
    });
    let t = tally.into_inner().unwrap();
    let elapsed = epoch.elapsed().as_secs_f64();
    eprintln!(
        "fuzz: {inputs} inputs (bytes {}, token soups {}, mutants {}) in {elapsed:.0} s ({:.0}/s, {jobs} workers); \
         {} checked clean and ran on both back ends ({} entries compared); {} panics, {} disagreements, 0 hangs",
        t.per_kind[0],
        t.per_kind[1],
        t.per_kind[2],
        inputs as f64 / elapsed,
        t.compiled,
        t.entries,
        t.panics,
        t.disagreements
    );
    assert_eq!((t.panics, t.disagreements), (0, 0), "findings saved under fuzz-failures/");
}
