//! UDIM tile sets end to end: a `"wood.<UDIM>.png"` path names tiles
//! 1001 + u + 10 v; lookups read the tile their (u, v) falls in, in both
//! back ends and color models; the set is listed at check time (no tile at
//! all is a located error), its tiles are read on first lookup (a bad tile
//! that no lookup reaches is harmless, one that is reached fails the
//! render naming it), and a mesh whose uv lie in a tile the set lacks is an
//! error when the scene is built.

use std::path::Path;
use std::sync::Arc;
use tsl::render::{self, Overrides, RenderOptions, Scene};
use tsl::texture::TextureManager;
use tsl::{Backend, ColorModel, Compiler, Program, ShadingGlobals};

mod common;
use common::temp_dir;

const RED: [u8; 3] = [255, 0, 0];
const GREEN: [u8; 3] = [0, 255, 0];
const BLUE: [u8; 3] = [0, 0, 255];

/// A 4 x 4 tile of one colour.
fn tile(dir: &Path, name: &str, rgb: [u8; 3]) {
    image::RgbImage::from_pixel(4, 4, image::Rgb(rgb)).save(dir.join(name)).unwrap();
}

/// Tiles 1001 (red), 1002 (green) and 1011 (blue) of `wood.<UDIM>.png`.
fn three_tiles(name: &str) -> std::path::PathBuf {
    let dir = temp_dir(name);
    tile(&dir, "wood.1001.png", RED);
    tile(&dir, "wood.1002.png", GREEN);
    tile(&dir, "wood.1011.png", BLUE);
    dir
}

fn compile_with(dir: &Path, src: &str, model: ColorModel, textures: Arc<TextureManager>) -> Program {
    let file = dir.join("shader.tsl");
    std::fs::write(&file, src).unwrap();
    Compiler::new().color_model(model).texture_manager(textures).file(&file).compile().unwrap_or_else(|e| panic!("{e}"))
}

fn compile(dir: &Path, src: &str, model: ColorModel) -> Program {
    compile_with(dir, src, model, Arc::new(TextureManager::new()))
}

/// `name()` at (u, v) in both back ends, which must agree bit for bit.
fn both(program: &Program, name: &str, u: f32, v: f32) -> Vec<f32> {
    let f = program.function(name).unwrap_or_else(|| panic!("no function {name}"));
    let g = ShadingGlobals { u, v, n: [0.0, 0.0, 1.0], ..Default::default() };
    let run = |backend| {
        let mut out = vec![0u32; f.result_types().len()];
        f.call_words(backend, &g, &[], &mut out).unwrap();
        out
    };
    let (jit, interp) = (run(Backend::Jit), run(Backend::Interpreter));
    assert_eq!(jit, interp, "{name} at ({u}, {v}): the back ends disagree");
    jit.into_iter().map(f32::from_bits).collect()
}

#[test]
fn each_tile_gives_its_colour_in_both_back_ends() {
    let dir = three_tiles("udim-colours");
    let src = r#"
        vector stored() { return texture_vector("wood.<UDIM>.png"); }
        vector filtered() { return to_rgb(texture("wood.<UDIM>.png", colorspace: "linear", filter: "bilinear")); }
        float green() { return texture_float("wood.<UDIM>.png", channel: 1, filter: "nearest"); }
        vector scaled() { return texture_vector("wood.<UDIM>.png", (u * 2, v)); }
    "#;
    let p = compile(&dir, src, ColorModel::Rgb);
    for f in ["stored", "filtered"] {
        assert_eq!(both(&p, f, 0.5, 0.5), [1.0, 0.0, 0.0], "{f}: tile 1001");
        assert_eq!(both(&p, f, 1.5, 0.5), [0.0, 1.0, 0.0], "{f}: tile 1002");
        assert_eq!(both(&p, f, 0.5, 1.5), [0.0, 0.0, 1.0], "{f}: tile 1011");
        // Tiles the set lacks and places off the grid are black.
        for (u, v) in [(2.5, 0.5), (1.5, 1.5), (-0.5, 0.5), (10.5, 0.5), (0.5, -0.5)] {
            assert_eq!(both(&p, f, u, v), [0.0; 3], "{f} at ({u}, {v})");
        }
        // Bilinear filtering stays inside a tile: no green at red's edge.
        assert_eq!(both(&p, f, 0.999, 0.5), [1.0, 0.0, 0.0], "{f}: 1001's right edge");
        assert_eq!(both(&p, f, 1.001, 0.5), [0.0, 1.0, 0.0], "{f}: 1002's left edge");
    }
    assert_eq!(both(&p, "green", 1.25, 0.75), [1.0]);
    assert_eq!(both(&p, "green", 0.25, 0.75), [0.0]);
    // Coordinates computed from (u, v) pick tiles too.
    assert_eq!(both(&p, "scaled", 0.75, 0.5), [0.0, 1.0, 0.0]);
}

#[test]
fn address_modes_apply_at_each_tiles_own_edges() {
    let dir = temp_dir("udim-wrap");
    // Tile 1001: a black left column, the rest white.
    let img = image::GrayImage::from_fn(4, 4, |x, _| image::Luma([if x == 0 { 0 } else { 255 }]));
    img.save(dir.join("edge.1001.png")).unwrap();
    let src = r#"
        float clamped() { return texture_float("edge.<UDIM>.png", filter: "bilinear"); }
        float repeated() { return texture_float("edge.<UDIM>.png", filter: "bilinear", wrap: "repeat"); }
    "#;
    let p = compile(&dir, src, ColorModel::Rgb);
    // Past the last texel centre: clamp (a tile set's default) reads the
    // tile's own right column, repeat blends in its left (black) column.
    assert_eq!(both(&p, "clamped", 0.99, 0.5), [1.0]);
    let r = both(&p, "repeated", 0.99, 0.5)[0];
    assert!(r > 0.5 && r < 0.9, "repeat wraps within the tile: {r}");
}

#[test]
fn spectral_lookups_read_the_tiles_spectra() {
    let dir = three_tiles("udim-spectral");
    let src = r#"color c() { return texture("wood.<UDIM>.png", filter: "nearest"); }"#;
    let p = compile(&dir, src, ColorModel::Spectral { samples: 8 });
    let (red, blue) = (both(&p, "c", 0.5, 0.5), both(&p, "c", 0.5, 1.5));
    // Long wavelengths come last: red rises toward them, blue falls.
    assert!(red[7] > red[0] && blue[0] > blue[7], "{red:?} / {blue:?}");
    assert!(both(&p, "c", 2.5, 0.5).iter().all(|&x| x == 0.0), "a missing tile is black");
    // Hero wavelengths (the globals' own, here all the same): the back ends agree.
    let p = compile(&dir, src, ColorModel::Hero);
    assert!(both(&p, "c", 0.5, 0.5).iter().any(|&x| x > 0.0));
    assert!(both(&p, "c", 2.5, 0.5).iter().all(|&x| x == 0.0));
}

#[test]
fn tiles_are_read_on_first_lookup_only() {
    let dir = three_tiles("udim-lazy");
    // A corrupt tile that no lookup reaches.
    std::fs::write(dir.join("wood.1012.png"), b"not a png").unwrap();
    let textures = Arc::new(TextureManager::new());
    let src = r#"vector c() { return texture_vector("wood.<UDIM>.png"); }"#;
    let p = compile_with(&dir, src, ColorModel::Rgb, textures.clone());
    assert_eq!(textures.loaded(), 0, "checking lists the tiles and reads none");
    assert_eq!(both(&p, "c", 0.5, 0.5), [1.0, 0.0, 0.0]);
    assert_eq!(textures.loaded(), 1, "one tile looked up, one read");
    both(&p, "c", 0.25, 0.25);
    assert_eq!(textures.loaded(), 1, "read once");
    assert_eq!(both(&p, "c", 1.5, 1.5), [0.0; 3], "the corrupt tile reads as black");
}

/// A scene looking straight at a unit quad that shows `texture`'s value.
fn quad_scene(texture: &str) -> String {
    format!(
        r#"material m = emitter({texture});
        scene {{
            camera {{ from (0.5, 0.5, 2); to (0.5, 0.5, 0); fov 20; }}
            render {{ width 8; height 8; spp 1; }}
            object quad {{ corner (0, 0, 0); edge1 (1, 0, 0); edge2 (0, 1, 0); material m; }}
        }}"#
    )
}

#[test]
fn a_bad_tile_fails_the_render_only_when_looked_up() {
    let dir = three_tiles("udim-render");
    std::fs::write(dir.join("wood.1003.png"), b"not a png").unwrap();
    // (u * 2, v): tiles 1001 and 1002 only; the bad 1003 is never read.
    let p =
        compile(&dir, &quad_scene(r#"texture("wood.<UDIM>.png", (u * 2, v), colorspace: "linear")"#), ColorModel::Rgb);
    let scene = Scene::build(&p, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    let image = render::render(&scene, &RenderOptions::default()).unwrap().0;
    let (left, right) = (image.color[4 * 8], image.color[4 * 8 + 7]);
    assert!(left[0] > 0.9 && left[1] < 0.1 && right[1] > 0.9 && right[0] < 0.1, "{left:?} {right:?}");
    // (u * 3, v) reaches tile 1003: the render is an error naming it.
    let p = compile(&dir, &quad_scene(r#"texture("wood.<UDIM>.png", (u * 3, v))"#), ColorModel::Rgb);
    let scene = Scene::build(&p, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    let e = render::render(&scene, &RenderOptions::default()).unwrap_err();
    assert!(e.contains("cannot read the UDIM tile 1003") && e.contains("wood.1003.png"), "{e}");
}

/// A square mesh whose uv span [u0, u0 + 0.5] x [v0, v0 + 0.5].
fn square_obj(dir: &Path, name: &str, u0: f32, v0: f32) {
    let (u1, v1) = (u0 + 0.5, v0 + 0.5);
    let text = format!(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt {u0} {v0}\nvt {u1} {v0}\nvt {u1} {v1}\nvt {u0} {v1}\n\
         f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    );
    std::fs::write(dir.join(name), text).unwrap();
}

fn mesh_scene(mesh: &str, texture: &str) -> String {
    format!(
        r#"material m = lambert(kd: {texture});
        scene {{
            camera {{ from (0.5, 0.5, 2); to (0.5, 0.5, 0); }}
            render {{ width 4; height 4; spp 1; }}
            light point {{ at (0.5, 0.5, 2); intensity gray(1); }}
            object mesh {{ file "{mesh}"; material m; }}
        }}"#
    )
}

#[test]
fn a_mesh_in_a_missing_tile_is_an_error_before_rendering() {
    let dir = three_tiles("udim-mesh");
    square_obj(&dir, "inside.obj", 1.25, 0.0);
    // Corners on a tile's edges belong to the tile the triangles are in.
    square_obj(&dir, "edges.obj", 0.5, 0.5);
    square_obj(&dir, "outside.obj", 2.25, 1.25);
    let build = |mesh: &str, texture: &str| {
        let p = compile(&dir, &mesh_scene(mesh, texture), ColorModel::Rgb);
        Scene::build(&p, &Overrides::default()).map(|_| ()).map_err(|e| e.to_string())
    };
    let at_uv = r#"texture("wood.<UDIM>.png")"#;
    assert_eq!(build("inside.obj", at_uv), Ok(()));
    assert_eq!(build("edges.obj", at_uv), Ok(()));
    let e = build("outside.obj", at_uv).unwrap_err();
    assert!(e.contains("outside.obj") && e.contains("UDIM tile 1013") && e.contains("wood.1013.png"), "{e}");
    assert!(e.contains("1001, 1002, 1011"), "the tiles there are: {e}");
    // At coordinates computed from (u, v) the mesh's uv do not say which
    // tiles are read: no check (the lookups there are black).
    assert_eq!(build("outside.obj", r#"texture("wood.<UDIM>.png", (u * 0.25, v * 0.25))"#), Ok(()));
}

#[test]
fn pattern_errors_and_off_grid_tiles_are_located() {
    let dir = three_tiles("udim-errors");
    tile(&dir, "wood.0999.png", RED);
    let check = |src: &str| {
        let file = dir.join("bad.tsl");
        std::fs::write(&file, src).unwrap();
        tsl::check_file(&file, &tsl::LoadOptions::default())
    };
    let c = check("color f() { return texture(\"oak.<UDIM>.png\"); }\n");
    let text = c.render_diagnostics();
    assert!(!c.is_ok(), "{text}");
    assert!(
        text.contains("no tile of the UDIM set `oak.<UDIM>.png` exists") && text.contains("bad.tsl:1:28"),
        "{text}"
    );
    assert!(text.contains(&format!("searched `{}`", dir.display())) && text.contains("`oak.1001.png`"), "{text}");
    let c = check("color f() { return texture(\"<UDIM>/wood.png\"); }\n");
    assert!(c.render_diagnostics().contains("must be in the file name"), "{}", c.render_diagnostics());
    // A file numbered off the grid is left out, with a warning.
    let c = check("color f() { return texture(\"wood.<UDIM>.png\"); }\n");
    let text = c.render_diagnostics();
    assert!(
        c.is_ok() && text.contains("warning") && text.contains("wood.0999.png") && text.contains("off the tile grid")
    );
}

#[test]
fn the_content_hash_follows_the_tiles_files() {
    let dir = three_tiles("udim-hash");
    let file = dir.join("scene.tsl");
    std::fs::write(&file, "color f() { return texture(\"wood.<UDIM>.png\"); }\n").unwrap();
    let hash = || {
        let c = tsl::check_file(&file, &tsl::LoadOptions::default());
        tsl::scene::content_hash(&c.program, c.scene.as_ref())
    };
    let before = hash();
    assert_eq!(before, hash());
    tile(&dir, "wood.1011.png", GREEN);
    assert_ne!(before, hash(), "a tile changed");
}
