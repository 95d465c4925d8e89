//! `include/tsl.h` is generated from `src/capi/` by cbindgen with the
//! root's `cbindgen.toml`; this test regenerates it and fails when the
//! checked-in header differs (`UPDATE_HEADER=1` rewrites it). cbindgen
//! reads `src/capi/` alone (no `cargo metadata`, so no other item of the
//! crate can reach the header).

use std::path::Path;

#[test]
fn checked_in_header_matches_the_generated_one() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(root.join("cbindgen.toml")).expect("cbindgen.toml reads");
    let bindings =
        cbindgen::Builder::new().with_crate(root).with_config(config).generate().expect("cbindgen reads src/capi/");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let generated = String::from_utf8(generated).expect("the header is UTF-8");
    let path = root.join("include/tsl.h");
    if std::env::var_os("UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("include/tsl.h is writable");
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        checked_in == generated,
        "include/tsl.h is stale: run `UPDATE_HEADER=1 cargo test --test c_header` and commit it\n\
         first difference at line {}",
        checked_in.lines().zip(generated.lines()).take_while(|(a, b)| a == b).count() + 1
    );
    for needle in ["#ifndef TSL_H", "tsl_compiler_compile", "TSL_OK = 0", "typedef struct TslProgram TslProgram;"] {
        assert!(generated.contains(needle), "the header lacks `{needle}`");
    }
    // Only the C API's own types: a public Rust type elsewhere in the crate
    // must not leak in (exclude it in cbindgen.toml).
    for line in generated.lines().filter(|l| l.starts_with("typedef struct") || l.starts_with("typedef enum")) {
        let name = line.split_whitespace().nth(2).unwrap_or_default();
        assert!(name.starts_with("Tsl"), "the header declares `{name}`, which is not part of the C API: {line}");
    }
}
