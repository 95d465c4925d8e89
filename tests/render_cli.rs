//! `tslc render` and `tslc merge` as users and render farms run them:
//! outputs, tiles joined bit for bit, progress on pipes, clear errors that
//! leave no file behind.

mod common;

use common::{stderr, tslc};
use std::path::PathBuf;
use std::process::{Command, Stdio};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tslc-render-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &std::path::Path) -> String {
    p.display().to_string()
}

#[test]
fn renders_a_png_with_progress_and_a_summary_on_a_pipe() {
    let dir = scratch("png");
    let out = dir.join("whitted.png");
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--res", "32x24", "--spp", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("progress: 100%"), "{err}");
    assert!(err.contains("rays/s") && err.contains("peak memory"), "{err}");
    let img = image::open(&out).unwrap().into_rgb8();
    assert_eq!(img.dimensions(), (32, 24));
    // The red and yellow floor is there.
    assert!(img.pixels().any(|p| p.0[0] > 100 && p.0[2] < 60));
    let quiet = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--res", "8x8", "--spp", "1", "--quiet"]);
    assert!(quiet.status.success() && quiet.stderr.is_empty(), "{}", stderr(&quiet));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn tiles_merge_into_the_same_bits_as_one_render() {
    let dir = scratch("tiles");
    let common = ["--res", "24x20", "--spp", "3", "--quiet", "--aov"];
    let full = dir.join("full.exr");
    let mut args = vec!["render", "examples/cornell.tsl", "-o"];
    let full_s = s(&full);
    args.push(&full_s);
    args.extend(common);
    assert!(tslc(&args).status.success());
    let mut tiles = Vec::new();
    for i in 0..3 {
        let path = s(&dir.join(format!("tile{i}.exr")));
        let tile = format!("{i}/3");
        let mut args = vec!["render", "examples/cornell.tsl", "-o", &path, "--tile", &tile, "--threads", "1"];
        args.extend(common);
        let o = tslc(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        tiles.push(path);
    }
    let merged = s(&dir.join("merged.exr"));
    let mut args = vec!["merge", "-o", &merged];
    args.extend(tiles.iter().map(String::as_str));
    let o = tslc(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let a = tsl::render::image_io::read_exr(&full).unwrap();
    let b = tsl::render::image_io::read_exr(std::path::Path::new(&merged)).unwrap();
    assert_eq!(
        a.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>(),
        b.color.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    );
    assert!(a.albedo.is_some() && a.albedo == b.albedo);
    assert!(a.object.is_some() && a.object == b.object);
    // A missing tile is reported.
    let o = tslc(&["merge", "-o", &merged, &tiles[0], &tiles[2]]);
    assert!(!o.status.success() && stderr(&o).contains("missing"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn light_sampling_is_chosen_on_the_command_line() {
    // Cornell has one light: choosing it by power is summing all lights.
    let dir = scratch("lights");
    let mut images = Vec::new();
    for sampling in ["all", "power"] {
        let out = dir.join(format!("{sampling}.exr"));
        let o = tslc(&[
            "render",
            "examples/cornell.tsl",
            "-o",
            &s(&out),
            "--res",
            "16x16",
            "--spp",
            "2",
            "--light-sampling",
            sampling,
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        images.push(tsl::render::image_io::read_exr(&out).unwrap().color);
    }
    assert_eq!(images[0], images[1]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn spectral_means_sampled_wavelengths_as_in_mitsuba_and_pbrt() {
    let dir = scratch("spectral");
    let render = |model: &str| {
        let out = dir.join(format!("{model}.exr"));
        let args = ["render", "examples/cornell.tsl", "-o", &s(&out), "--res", "12x12", "--spp", "2", "--quiet"];
        let o = tslc(&[&args[..], &["--color-model", model]].concat());
        assert!(o.status.success(), "{model}: {}", stderr(&o));
        tsl::render::image_io::read_exr(&out).unwrap().color
    };
    let spectral = render("spectral");
    assert_eq!(spectral, render("hero"));
    assert_ne!(spectral, render("spectral16"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// One vocabulary, as cargo and rustc: `--color` is when to colour
/// diagnostics, `--color-model` what a color is.
#[test]
fn color_is_terminal_colour_and_color_model_the_model() {
    let dir = scratch("color-flags");
    let new = dir.join("new.exr");
    let model = |m: &str| {
        let args = ["render", "examples/cornell.tsl", "-o", &s(&new), "--res", "12x12", "--spp", "2", "--quiet"];
        assert!(tslc(&[&args[..], &["--color-model", m]].concat()).status.success());
        tsl::render::image_io::read_exr(&new).unwrap().color
    };
    // The old spelling, `--color MODEL`, renders the same with a warning;
    // `--color` is otherwise when to colour diagnostics, as in cargo.
    let out = dir.join("old.exr");
    let args = ["render", "examples/cornell.tsl", "-o", &s(&out), "--res", "12x12", "--spp", "2", "--quiet"];
    let o = tslc(&[&args[..], &["--color", "spectral"][..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("warning: `--color spectral` is the old spelling of `--color-model spectral`"),
        "{}",
        stderr(&o)
    );
    assert_eq!(tsl::render::image_io::read_exr(&out).unwrap().color, model("spectral"));
    let o = tslc(&[&args[..], &["--color", "never"][..]].concat());
    assert!(o.status.success() && stderr(&o).is_empty(), "{}", stderr(&o));
    let o = tslc(&[&args[..], &["--color", "sometimes"][..]].concat());
    assert!(stderr(&o).contains("`sometimes` is not auto, always or never"), "{}", stderr(&o));
    // `check` takes no model: a model given as `--color` says where models go.
    let o = tslc(&["check", "examples/cornell.tsl", "--color", "spectral"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("`spectral` is a color model, and `--color` is when to colour diagnostics"),
        "{}",
        stderr(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_invocations_are_clear_errors_and_write_nothing() {
    let dir = scratch("bad");
    let out = dir.join("out.png");
    let o = tslc(&["render", "no/such/scene.tsl", "-o", &s(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("scene.tsl"), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--res", "0x5"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--tile", "3/3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--tile", "0/3", "--res", "8x8"]);
    assert!(stderr(&o).contains(".exr"), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&dir.join("x.bmp")), "--res", "8x8", "--quiet"]);
    assert!(!o.status.success() && stderr(&o).contains(".png or .exr"), "{}", stderr(&o));
    // Missing directories of the output are made, as `mkdir -p`.
    let nested = dir.join("new/sub/x.png");
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&nested), "--res", "8x8", "--quiet"]);
    assert!(o.status.success() && nested.is_file(), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&dir.join("other/x.jpg")), "--res", "8x8", "--quiet"]);
    assert!(!o.status.success() && !dir.join("other").exists(), "a refused output makes no directory");
    std::fs::write(dir.join("afile"), "").unwrap();
    // Output problems are found before any rendering (no progress line),
    // and name the user's path.
    std::fs::create_dir_all(dir.join("d.png")).unwrap();
    let cases =
        [("afile/x.png", "cannot create the directory"), ("x.jpg", ".png or .exr"), ("d.png", "is a directory")];
    for (target, why) in cases {
        let target = dir.join(target);
        let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&target), "--res", "8x8"]);
        let err = stderr(&o);
        assert!(!o.status.success() && err.contains(why) && err.contains(&s(&target)), "{err}");
        assert!(!err.contains("progress") && !err.contains("rendered"), "{err}");
    }
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--crop", "0,1.5,0,1", "--res", "8x8"]);
    assert!(!o.status.success() && stderr(&o).contains("neither a fraction"), "{}", stderr(&o));
    // Every count has a bound, and a negative number gets the same message.
    for (flag, value, why) in [
        ("--spp", "0", "samples per pixel must be a whole number from 1 to 1048576"),
        ("--spp", "-1", "samples per pixel must be a whole number from 1 to 1048576"),
        ("--max-depth", "0", "the maximum depth must be a whole number from 1 to 1024"),
        ("--seed", "-1", "the seed must be a whole number from 0"),
        ("--threads", "10000", "the thread count must be a whole number from 0 to 1024"),
        ("--res", "65536x65536", "more than the 134217728 pixels"),
    ] {
        let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), flag, value]);
        assert!(o.status.code() == Some(2) && stderr(&o).contains(why), "{flag} {value}: {}", stderr(&o));
    }
    // A scene without light renders, with a warning.
    let dark = dir.join("dark.tsl");
    std::fs::write(&dark, "scene {\n    camera { from (0, 0, -4); to (0, 0, 0); }\n    object sphere { center (0, 0, 0); radius 1; material lambert; }\n}\n").unwrap();
    let dark_out = dir.join("dark.png");
    let o = tslc(&["render", &s(&dark), "-o", &s(&dark_out), "--res", "8x8", "--spp", "1"]);
    assert!(o.status.success() && stderr(&o).contains("warning: the scene has no light"), "{}", stderr(&o));
    let _ = std::fs::remove_file(&dark_out);
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&dark_out), "--res", "8x8", "--spp", "1"]);
    assert!(!stderr(&o).contains("no light"), "{}", stderr(&o));
    let _ = std::fs::remove_file(&dark_out);
    // A file without a scene is named.
    let no_scene = dir.join("no_scene.tsl");
    std::fs::write(&no_scene, "material m = lambert;\n").unwrap();
    let o = tslc(&["render", &s(&no_scene), "-o", &s(&out)]);
    assert!(stderr(&o).contains("no_scene.tsl:1:1") && !stderr(&o).contains("<tsl>"), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--light-sampling", "some"]);
    assert!(o.status.code() == Some(2) && stderr(&o).contains("all or power"), "{}", stderr(&o));
    let o = tslc(&["render", "examples/whitted.tsl", "-o", &s(&out), "--crop", "0.5,0.5,0,1", "--res", "8x8"]);
    assert!(!o.status.success() && stderr(&o).contains("empty"), "{}", stderr(&o));
    // A scene with an error is reported with its location.
    let bad = dir.join("bad.tsl");
    std::fs::write(&bad, "scene {\n    camera { from (0, 0, 1); to (0, 0, 1); }\n}\n").unwrap();
    let o = tslc(&["render", &s(&bad), "-o", &s(&out)]);
    assert!(!o.status.success() && stderr(&o).contains("bad.tsl:2:"), "{}", stderr(&o));
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().contains("tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGINT or SIGTERM while a large EXR is being written leaves neither a
/// truncated target nor the temporary beside it.
#[test]
fn an_interrupted_write_leaves_nothing_behind() {
    use std::io::BufRead;
    let dir = scratch("signals");
    let scene = dir.join("big.tsl");
    std::fs::write(
        &scene,
        "scene {\n    camera { from (0, 0, -4); to (0, 0, 0); }\n    render { integrator \"whitted\"; spp 1; }\n    \
         light point { at (2, 3, -4); intensity gray(20); }\n    object sphere { center (0, 0, 0); radius 1; material lambert; }\n}\n",
    )
    .unwrap();
    for signal in ["-INT", "-TERM"] {
        let out = dir.join("big.exr");
        let mut child = Command::new(env!("CARGO_BIN_EXE_tslc"))
            .args(["render", &s(&scene), "-o", &s(&out), "--res", "1024x1024", "--aov"])
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The film is done; signal once the temporary of the write (about
        // 16 MB of EXR) is there.
        let lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
        for line in lines.map_while(Result::ok) {
            if line.contains("progress: 100%") {
                break;
            }
        }
        let temporary =
            || std::fs::read_dir(&dir).unwrap().any(|e| e.unwrap().file_name().to_string_lossy().contains(".tmp-"));
        let start = std::time::Instant::now();
        while !temporary() && start.elapsed().as_secs() < 30 {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        assert!(temporary(), "{signal}: the write never started");
        let killed = Command::new("kill").args([signal, &child.id().to_string()]).status().unwrap();
        assert!(killed.success());
        let status = child.wait().unwrap();
        let names: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        assert!(!names.iter().any(|n| n.contains(".tmp-")), "{signal}: {names:?} (exit {status:?})");
        // The target is absent, or whole if the write finished first.
        if out.exists() {
            assert!(tsl::render::image_io::read_exr(&out).is_ok(), "{signal}: a truncated target");
            let _ = std::fs::remove_file(&out);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `tslc view`: every layer of an EXR as a PNG whose pixels are the
/// layer's mapped values, or drawn in the terminal; a missing layer names
/// `--aov`.
#[test]
fn view_shows_each_layer_of_an_exr() {
    let dir = scratch("view");
    let exr = dir.join("shot.exr");
    let o =
        tslc(&["render", "examples/cornell.tsl", "-o", &s(&exr), "--res", "20x10", "--spp", "2", "--aov", "--quiet"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let image = tsl::render::image_io::read_exr(&exr).unwrap();
    for layer in ["color", "albedo", "normal", "depth", "object"] {
        let png = dir.join(format!("{layer}.png"));
        let o = tslc(&["view", &s(&exr), "--layer", layer, "-o", &s(&png)]);
        assert!(o.status.success(), "{layer}: {}", stderr(&o));
        let picture = image::open(&png).unwrap().to_rgb8();
        assert_eq!(picture.dimensions(), (20, 10), "{layer}");
        let name = tsl::render::image_io::LayerName::parse(layer).unwrap();
        let want = tsl::render::image_io::layer_rgb8(&image, name).unwrap();
        assert_eq!(picture.pixels().map(|p| p.0).collect::<Vec<_>>(), want, "{layer}");
    }
    // A normal facing the camera is the normal-map blue.
    let normals = image::open(dir.join("normal.png")).unwrap().to_rgb8();
    let centre = image.normal.as_ref().unwrap()[5 * 20 + 10];
    assert_eq!(normals.get_pixel(10, 5).0, centre.map(|x| ((x + 1.0) * 127.5).round() as u8));
    // In the terminal: 24-bit colours, two rows a line.
    let o = tslc(&["view", &s(&exr), "--layer", "albedo", "--columns", "10"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && text.lines().count() == 3 && text.contains("\x1b[38;2;"), "{text}");
    assert_eq!(text.lines().next().unwrap().matches('▀').count(), 10);
    let plain = dir.join("plain.exr");
    assert!(
        tslc(&["render", "examples/cornell.tsl", "-o", &s(&plain), "--res", "8x8", "--spp", "1", "--quiet"])
            .status
            .success()
    );
    let o = tslc(&["view", &s(&plain), "--layer", "depth"]);
    assert!(
        !o.status.success() && stderr(&o).contains("no depth layer") && stderr(&o).contains("--aov"),
        "{}",
        stderr(&o)
    );
    let o = tslc(&["view", &s(&exr), "-o", &s(&dir.join("x.exr"))]);
    assert!(!o.status.success() && stderr(&o).contains(".png"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Stanford PLY mesh (quads fanned into triangles) renders as the same
/// mesh in OBJ does: examples/prism.ply (the example's) against examples/prism.obj.
#[test]
fn ply_meshes_render_as_the_same_obj() {
    let dir = scratch("ply");
    let scene = std::fs::read_to_string("examples/prism.tsl").unwrap();
    assert!(scene.contains("\"prism.ply\""), "the example names its mesh");
    let mut images = Vec::new();
    for mesh in ["prism.obj", "prism.ply"] {
        std::fs::copy(format!("examples/{mesh}"), dir.join(mesh)).unwrap();
        let path = dir.join(format!("{mesh}.tsl"));
        std::fs::write(&path, scene.replace("\"prism.ply\"", &format!("\"{mesh}\""))).unwrap();
        let out = dir.join(format!("{mesh}.exr"));
        let o = tslc(&["render", &s(&path), "-o", &s(&out), "--res", "24x16", "--spp", "2", "--quiet"]);
        assert!(o.status.success(), "{mesh}: {}", stderr(&o));
        images.push(tsl::render::image_io::read_exr(&out).unwrap().color);
    }
    assert!(images[0].iter().any(|p| p[0] > 0.0));
    assert_eq!(images[0], images[1]);
    let _ = std::fs::remove_dir_all(&dir);
}
