//! The render-farm path: animation frames (`frame` and `time` in shaders
//! and scene values, `--frame`, `--frames`, frame-numbered outputs),
//! frames rendered one per task giving the bits of a sequence, and tiles
//! that say what made them: `tslc merge` refuses parts that disagree,
//! names missing tiles by number and writes the same bytes every time;
//! `tslc info` prints it all.

mod common;

use common::{stderr, tslc};
use std::path::{Path, PathBuf};
use std::process::Output;
use tsl::Compiler;
use tsl::render::{self, Overrides, RenderOptions, Scene};
use tsl::scene::FrameRequest;

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// The color of `src`'s scene rendered at `frame`, as bits.
fn render_at(src: &str, frame: i32, fps: Option<f32>) -> Vec<[u32; 3]> {
    let program = Compiler::new().source("anim.tsl", src).compile().unwrap_or_else(|e| panic!("{e}"));
    let desc = program.scene_at(&FrameRequest { frame, fps }).unwrap_or_else(|e| panic!("{e}"));
    let scene = Scene::build_from(&program, desc.as_ref(), &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    let image = render::render(&scene, &RenderOptions::default()).unwrap().0;
    image.color.iter().map(|p| p.map(f32::to_bits)).collect()
}

/// A scene whose camera, stripes and image texture move with `time`, and
/// whose sphere rises with `frame`, written as `time` and `frame` or, for
/// comparison, as the numbers they are at one frame.
fn moving(time: &str, frame: &str) -> String {
    let painting = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/textures/painting.png");
    r#"
    float stripes(float offset) { return step(0.5, fract(u * 6 + offset)); }
    material striped = mix(stripes(TIME), lambert(kd: rgb(0.8, 0.2, 0.1)), lambert(kd: rgb(0.1, 0.2, 0.8)));
    material painted = lambert(kd: texture("PAINTING", (u * 2 + TIME, v), wrap: "repeat"));
    scene {
        camera { from (TIME, 1.2, -4); to (0, 0.6, 0); fov 40; }
        render { width 24; height 18; spp 2; max_depth 3; }
        light point { at (2, 4, -3); intensity gray(30); }
        object sphere { center (-0.6, 0.5 + 0.05 * FRAME, 0); radius 0.5; material striped; }
        object sphere { center (0.6, 0.5, 0); radius 0.5; material painted; }
        object plane { point (0, 0, 0); normal (0, 1, 0); material lambert; }
    }
    "#
    .replace("TIME", time)
    .replace("FRAME", frame)
    .replace("PAINTING", &painting.display().to_string())
}

#[test]
fn frame_and_time_move_the_camera_offset_textures_and_enter_the_seed() {
    let animated = moving("time", "float(frame)");
    // Frame 12 at 24 frames per second is at 0.5 s.
    let fixed = moving("0.5", "12");
    let moved = render_at(&animated, 12, Some(24.0));
    assert_eq!(moved, render_at(&fixed, 12, Some(24.0)), "time and frame are not 0.5 and 12 at frame 12");
    // The scene's own frame rate and the `time` mapping give the same.
    let at_fps = animated.replace("max_depth 3;", "max_depth 3; fps 24;");
    assert_eq!(moved, render_at(&at_fps, 12, None));
    let mapped = animated.replace("max_depth 3;", "max_depth 3; time frame / 48.0 + 0.25;");
    assert_eq!(moved, render_at(&mapped, 12, None));
    // Another frame moves things; the same scene at another frame has
    // other noise (the frame enters the seed), and frame 0 keeps the seed.
    let still = render_at(&fixed, 0, None);
    assert_ne!(render_at(&animated, 0, None), moved);
    assert_ne!(still, render_at(&fixed, 12, None));
    assert_eq!(still, render_at(&fixed.replace("max_depth 3;", "max_depth 3; seed 0;"), 0, None));
}

#[test]
fn a_value_invalid_at_one_frame_is_an_error_naming_the_frame() {
    let src = "scene { camera { from (0, 1, -4 + frame); to (0, 1, 0); } }";
    let program = Compiler::new().source("anim.tsl", src).compile().unwrap();
    assert!(program.scene_at(&FrameRequest { frame: 3, fps: None }).is_ok());
    let e = program.scene_at(&FrameRequest { frame: 4, fps: None }).unwrap_err().to_string();
    assert!(e.contains("looks from a point to itself") && e.contains("at frame 4") && e.contains("anim.tsl:1:"), "{e}");
    let e = program.scene_at(&FrameRequest { frame: 3, fps: Some(-1.0) }).unwrap_err().to_string();
    assert!(e.contains("frame rate"), "{e}");
    let e = program.scene_at(&FrameRequest { frame: 2_000_000, fps: None }).unwrap_err().to_string();
    assert!(e.contains("out of range"), "{e}");
}

fn scratch(name: &str) -> PathBuf {
    common::temp_dir(&format!("farm-{name}"))
}

#[test]
fn frame_3_alone_is_the_third_frame_of_a_sequence() {
    let dir = scratch("frames");
    let scene = dir.join("anim.tsl");
    std::fs::write(&scene, moving("time", "float(frame)")).unwrap();
    let (scene, seq, one) = (s(&scene), s(&dir.join("seq.####.exr")), s(&dir.join("one.exr")));
    let o = tslc(&["render", &scene, "-o", &seq, "--frames", "1..3", "--fps", "6", "--threads", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("rendered frame 2 "), "{}", stderr(&o));
    let o = tslc(&["render", &scene, "-o", &one, "--frame", "3", "--fps", "6", "--quiet", "--threads", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same pixels and the same header: the same bytes.
    let third = std::fs::read(dir.join("seq.0003.exr")).unwrap();
    assert_eq!(third, std::fs::read(&one).unwrap());
    let read = |p: &Path| tsl::image_io::read_exr(p).unwrap().color;
    assert_ne!(read(&dir.join("seq.0003.exr")), read(&dir.join("seq.0002.exr")));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn frame_options_are_checked_before_any_frame_renders() {
    let dir = scratch("frame-errors");
    let scene = dir.join("anim.tsl");
    std::fs::write(&scene, "scene { camera { from (0, 1, -4 + frame); to (0, 1, 0); } render { width 8; height 8; } }")
        .unwrap();
    let scene = s(&scene);
    let out = s(&dir.join("f.##.png"));
    // Frame 4 puts the camera on the point it looks at: nothing is written.
    let o = tslc(&["render", &scene, "-o", &out, "--frames", "1..6", "--quiet"]);
    assert!(!o.status.success() && stderr(&o).contains("at frame 4"), "{}", stderr(&o));
    assert!(!dir.join("f.01.png").exists());
    let o = tslc(&["render", &scene, "-o", &s(&dir.join("f.png")), "--frames", "1..3"]);
    assert!(!o.status.success() && stderr(&o).contains("run of `#`"), "{}", stderr(&o));
    for bad in ["3..1", "1..x", "0..2000000"] {
        let o = tslc(&["render", &scene, "-o", &out, "--frames", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
    }
    let o = tslc(&["render", &scene, "-o", &out, "--frame", "1", "--frames", "1..2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = tslc(&["render", &scene, "-o", &out, "--frame", "-2", "--quiet"]);
    assert!(o.status.success() && dir.join("f.-2.png").exists(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Renders tiles `which` of `count` of `scene` into `dir` as `tile-I.exr`,
/// with `extra` options; returns their paths.
fn render_tiles(scene: &str, dir: &Path, count: u32, which: &[u32], extra: &[&str]) -> Vec<String> {
    which
        .iter()
        .map(|i| {
            let out = s(&dir.join(format!("tile-{i}.exr")));
            let tile = format!("{i}/{count}");
            let mut args = vec!["render", scene, "-o", &out, "--tile", &tile, "--quiet", "--threads", "1"];
            args.extend(extra);
            let o = tslc(&args);
            assert!(o.status.success(), "{}", stderr(&o));
            out
        })
        .collect()
}

fn merge(inputs: &[&str], out: &Path) -> Output {
    let out = s(out);
    let mut args = vec!["merge", "-o", &out];
    args.extend(inputs);
    tslc(&args)
}

#[test]
fn merged_tiles_are_the_bytes_of_one_render_and_merge_names_what_is_wrong() {
    let dir = scratch("merge");
    let scene = dir.join("shot.tsl");
    std::fs::write(&scene, moving("time", "float(frame)")).unwrap();
    let scene = s(&scene);
    let extra = ["--frame", "2", "--aov"];
    let tiles = render_tiles(&scene, &dir, 4, &[0, 1, 2, 3], &extra);
    let tiles: Vec<&str> = tiles.iter().map(String::as_str).collect();
    let full = dir.join("full.exr");
    let o = tslc(&["render", &scene, "-o", &s(&full), "--frame", "2", "--aov", "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Merged in any order, any number of times: the bytes of the full render.
    let full = std::fs::read(&full).unwrap();
    for (k, order) in [[0, 1, 2, 3], [3, 1, 0, 2], [2, 3, 1, 0]].iter().enumerate() {
        let out = dir.join(format!("merged{k}.exr"));
        let inputs: Vec<&str> = order.iter().map(|&i| tiles[i]).collect();
        let o = merge(&inputs, &out);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(std::fs::read(&out).unwrap() == full, "merge {k} is not the full render's bytes");
    }
    let out = dir.join("bad.exr");
    // Missing tiles are named by number, as an array to resubmit.
    let o = merge(&[tiles[0], tiles[2]], &out);
    let err = stderr(&o);
    assert!(err.contains("missing tiles 1 and 3 of 4: rerun with --array=1,3"), "{err}");
    let o = merge(&[tiles[0], tiles[1], tiles[1], tiles[2], tiles[3]], &out);
    assert!(stderr(&o).contains("tile 1 of 4 is given twice"), "{}", stderr(&o));
    // A tile rendered with other settings, another frame or another scene
    // is refused, naming the attribute and the file.
    let odd = scratch("merge-odd");
    for (what, options) in [
        ("tsl:spp", vec!["--spp", "3"]),
        ("tsl:seed", vec!["--seed", "7"]),
        ("tsl:integrator", vec!["--integrator", "whitted"]),
        ("tsl:colorModel", vec!["--color-model", "spectral8"]),
        ("tsl:frame", vec!["--frame", "3"]),
    ] {
        let mut options = options;
        if what != "tsl:frame" {
            options.extend(["--frame", "2"]);
        }
        options.push("--aov");
        let other = render_tiles(&scene, &odd, 4, &[3], &options);
        let o = merge(&[tiles[0], tiles[1], tiles[2], &other[0]], &out);
        let err = stderr(&o);
        assert!(!o.status.success() && err.contains(what) && err.contains(&other[0]), "{what}: {err}");
    }
    let changed = odd.join("shot.tsl");
    std::fs::write(&changed, std::fs::read_to_string(&scene).unwrap().replace("gray(30)", "gray(31)")).unwrap();
    let other = render_tiles(&s(&changed), &odd, 4, &[3], &extra);
    let err = stderr(&merge(&[tiles[0], tiles[1], tiles[2], &other[0]], &out));
    assert!(err.contains("tsl:sceneHash"), "{err}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&odd);
}

#[test]
fn info_prints_what_made_an_image_for_people_and_scripts() {
    let dir = scratch("info");
    let extra = ["--res", "12x9", "--spp", "2", "--frame", "5", "--seed", "18446744073709551615"];
    let tiles = render_tiles("examples/cornell.tsl", &dir, 3, &[2], &extra);
    let o = tslc(&["info", &tiles[0]]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    for expected in ["resolution         12x9", "y 6..9 (12x3 pixels)", "tsl:spp            2", "tsl:tile           2"]
    {
        assert!(text.contains(expected), "{expected}: {text}");
    }
    let o = tslc(&["info", "--json", &tiles[0], &tiles[0]]);
    let lines: Vec<serde_json::Value> =
        String::from_utf8_lossy(&o.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 2);
    let a = &lines[0]["attributes"];
    assert_eq!((a["tsl:tile"].as_i64(), a["tsl:tiles"].as_i64(), a["tsl:frame"].as_i64()), (Some(2), Some(3), Some(5)));
    assert_eq!(a["tsl:sceneHash"].as_str().map(str::len), Some(64));
    // Numbers are JSON numbers, the 64-bit seed (text in the EXR) exactly.
    assert_eq!((a["tsl:spp"].as_u64(), a["tsl:seed"].as_u64()), (Some(2), Some(u64::MAX)));
    assert_eq!(lines[0]["window"]["y"].as_i64(), Some(6));
    let o = tslc(&["info", &s(&dir.join("none.exr"))]);
    assert!(!o.status.success() && stderr(&o).contains("none.exr"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}
