//! The files tslc creates, reads and overwrites, as a neighbour in a
//! shared, group-writable folder and a careless user meet them: links
//! planted where tslc used to put its temporaries, outputs that are the
//! scene's own inputs, and `tslc fmt` on links, shared files, special
//! files and directory trees with loops.

#![cfg(unix)]

mod common;

use common::{stderr, temp_dir};
use std::os::unix::fs::{MetadataExt, PermissionsExt, symlink};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const TSLC: &str = env!("CARGO_BIN_EXE_tslc");

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Runs `command`, failing the test if it has not finished within 60 s
/// (a hang guard: every case here takes well under a second or two).
fn run(mut command: Command) -> Output {
    let mut child = command.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{command:?} did not finish within 60 s");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait_with_output().unwrap()
}

fn tslc(args: &[&str]) -> Output {
    let mut command = Command::new(TSLC);
    command.args(args);
    run(command)
}

/// `tslc args`, started by a shell that first plants, in `dir`, a symbolic
/// link to `victim` at each of `names`, where `$$` is the process id tslc
/// then runs with (`exec` keeps it): the names the old scheme chose.
fn tslc_among_links(dir: &Path, victim: &Path, names: &[&str], args: &[&str]) -> Output {
    let plant: String = names.iter().map(|n| format!("ln -s '{}' \"{}/{n}\" && ", s(victim), s(dir))).collect();
    let mut command = Command::new("sh");
    command.arg("-c").arg(format!("umask 027 && {plant}exec \"$0\" \"$@\"")).arg(TSLC).args(args);
    run(command)
}

fn is_link_to(path: &Path, target: &Path) -> bool {
    std::fs::read_link(path).is_ok_and(|t| t == target)
}

fn is_regular(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_file())
}

/// A lit scene that renders in a moment.
const SMALL_SCENE: &str = "scene {\n    camera { from (0, 0, -4); to (0, 0, 0); }\n    \
    light point { at (2, 3, -4); intensity gray(20); }\n    \
    object sphere { center (0, 0, 0); radius 1; material lambert; }\n}\n";

/// An EXR tile `index` of `count` of an 8 x 6 image, as `render --tile`
/// writes them.
fn write_tile(path: &Path, index: u32, count: u32) {
    let (x0, y0, width, height) = tsl::image_io::tile_window(8, 6, index, count).unwrap();
    let n = (width * height) as usize;
    let image = tsl::image_io::RenderedImage {
        full_width: 8,
        full_height: 6,
        x0,
        y0,
        width,
        height,
        color: vec![[index as f32, 0.5, 0.25]; n],
        albedo: None,
        normal: None,
        depth: None,
        object: None,
    };
    tsl::image_io::write_image(path, &image).unwrap();
}

#[test]
fn links_planted_at_the_names_tslc_used_to_choose_are_never_followed() {
    let dir = temp_dir("files-planted");
    let victim = dir.join("victim.txt");
    let precious = "another user's file\n";
    std::fs::write(&victim, precious).unwrap();
    let scene = dir.join("scene.tsl");
    std::fs::write(&scene, SMALL_SCENE).unwrap();
    write_tile(&dir.join("t0.exr"), 0, 2);
    write_tile(&dir.join("t1.exr"), 1, 2);
    std::fs::write(dir.join("a.tsl"), "float   f( ) {return 1;}\n").unwrap();
    let (out, frames, merged, source, mesh) =
        (dir.join("out.png"), dir.join("f.#.png"), dir.join("merged.exr"), dir.join("a.tsl"), dir.join("m.obj"));
    let render = ["render", &s(&scene), "--res", "8x8", "--spp", "1", "--quiet"];
    let cases: Vec<(Vec<&str>, Vec<String>, Vec<PathBuf>)> = vec![
        (
            vec![".tslc-probe-$$", ".out.png.tmp-$$-0.png", ".out.png.tmp-$$-1.png"],
            [&render[..], &["-o", &s(&out)]].concat().iter().map(|a| a.to_string()).collect(),
            vec![out.clone()],
        ),
        (
            vec![".tslc-probe-$$", ".f.1.png.tmp-$$-0.png", ".f.2.png.tmp-$$-1.png"],
            [&render[..], &["-o", &s(&frames), "--frames", "1..2"]].concat().iter().map(|a| a.to_string()).collect(),
            vec![dir.join("f.1.png"), dir.join("f.2.png")],
        ),
        (
            vec![".tslc-probe-$$", ".merged.exr.tmp-$$-0.exr"],
            ["merge", "-o", &s(&merged), &s(&dir.join("t0.exr")), &s(&dir.join("t1.exr"))]
                .iter()
                .map(|a| a.to_string())
                .collect(),
            vec![merged.clone()],
        ),
        (vec![".a.tsl.tmp-$$-0.tsl"], vec!["fmt".into(), s(&source)], vec![source.clone()]),
        (vec!["m.tmp-$$"], vec!["make-mesh".into(), "heavy".into(), "-o".into(), s(&mesh)], vec![mesh.clone()]),
    ];
    for (names, args, outputs) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = tslc_among_links(&dir, &victim, &names, &args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        assert_eq!(std::fs::read_to_string(&victim).unwrap(), precious, "{args:?} wrote into the victim");
        for output in &outputs {
            assert!(is_regular(output), "{args:?}: {} is not a regular file", s(output));
        }
        // The links are someone else's: left as they were.
        let planted: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| std::fs::symlink_metadata(p).unwrap().file_type().is_symlink())
            .collect();
        assert_eq!(planted.len(), names.len(), "{args:?}: {planted:?}");
        assert!(planted.iter().all(|p| is_link_to(p, &victim)), "{args:?}: {planted:?}");
        for p in planted {
            std::fs::remove_file(p).unwrap();
        }
    }
    // Outputs are created as any file the user makes (0666 less the umask).
    assert_eq!(std::fs::metadata(&out).unwrap().mode() & 0o777, 0o640);
    assert_eq!(std::fs::metadata(&merged).unwrap().mode() & 0o777, 0o640);
    assert!(std::fs::read_to_string(&source).unwrap().starts_with("float f() {"));
    let leftovers: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-") || n.contains("probe"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene reading one of each kind of input, and the line each is named on.
fn scene_with_every_input(dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("lib.tsl"), "float helper() {\n    return 1;\n}\n").unwrap();
    image::save_buffer(dir.join("t.png"), &[200, 100, 50, 10, 20, 30], 2, 1, image::ColorType::Rgb8).unwrap();
    image::save_buffer(dir.join("sky.png"), &[90, 120, 200, 90, 120, 200], 2, 1, image::ColorType::Rgb8).unwrap();
    std::fs::write(dir.join("m.obj"), "v -1 -1 1\nv 1 -1 1\nv 0 1 1\nf 1 2 3\n").unwrap();
    let scene = dir.join("scene.tsl");
    std::fs::write(
        &scene,
        "import \"lib.tsl\";\n\
         material m = lambert(kd: texture(\"t.png\"));\n\
         scene {\n    \
             camera { from (0, 0, -4); to (0, 0, 0); }\n    \
             light environment { file \"sky.png\"; }\n    \
             object mesh { file \"m.obj\"; material m; }\n    \
             object sphere { center (0, 0, 0); radius 0.5; material m; }\n\
         }\n",
    )
    .unwrap();
    scene
}

/// Every file in `dir` (not following links) with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| is_regular(p))
        .map(|p| {
            let bytes = std::fs::read(&p).unwrap();
            (p, bytes)
        })
        .collect();
    files.sort();
    files
}

#[test]
fn rendering_onto_one_of_the_scenes_inputs_is_refused_before_any_work() {
    let dir = temp_dir("files-inputs");
    let scene = scene_with_every_input(&dir);
    let at = |p: &str| dir.join(p);
    std::fs::hard_link(at("scene.tsl"), at("source.png")).unwrap();
    symlink(at("scene.tsl"), at("source.exr")).unwrap();
    symlink("lib.tsl", at("import.png")).unwrap();
    std::fs::hard_link(at("t.png"), at("hard.png")).unwrap();
    symlink(&dir, at("linked")).unwrap();
    std::fs::hard_link(at("m.obj"), at("mesh.png")).unwrap();
    std::fs::hard_link(at("sky.png"), at("f.2.png")).unwrap();
    let before = snapshot(&dir);
    // (output, extra arguments, what the message says, where it points)
    let cases: [(PathBuf, &[&str], &str, &str); 10] = [
        (at("source.png"), &[], "the source", "scene.tsl"),
        (at("source.exr"), &[], "the source", "scene.tsl"),
        (at("import.png"), &[], "an imported file", "lib.tsl"),
        (at("t.png"), &[], "a texture", "scene.tsl:2:34"),
        (at("hard.png"), &[], "a texture", "scene.tsl:2:34"),
        (at("linked/t.png"), &[], "a texture", "scene.tsl:2:34"),
        (at("sub/../t.png"), &[], "a texture", "scene.tsl:2:34"),
        (at("mesh.png"), &[], "a mesh", "scene.tsl:6:"),
        (at("sky.png"), &[], "the environment image", "scene.tsl:5:"),
        (at("f.#.png"), &["--frames", "1..3"], "the environment image", "scene.tsl:5:"),
    ];
    for (output, extra, role, location) in cases {
        let scene_s = s(&scene);
        let mut args = vec!["render", &scene_s, "--res", "8x8", "--spp", "1"];
        let output_s = s(&output);
        args.extend(["-o", &output_s]);
        args.extend(extra);
        let o = tslc(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{output_s}: {err}");
        assert!(err.contains("cannot write") && err.contains(role) && err.contains(location), "{output_s}: {err}");
        assert!(err.contains("would overwrite"), "{err}");
        assert!(!err.contains("progress") && !err.contains("rendered"), "{output_s}: rendered first: {err}");
        assert_eq!(snapshot(&dir), before, "{output_s}: a file changed");
    }
    // Another file is written as usual.
    let o = tslc(&["render", &s(&scene), "--res", "8x8", "--spp", "1", "--quiet", "-o", &s(&at("fine.png"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn watch_refuses_an_output_that_is_one_of_the_scenes_inputs() {
    let dir = temp_dir("files-watch");
    let scene = scene_with_every_input(&dir);
    let texture = std::fs::read(dir.join("t.png")).unwrap();
    std::fs::hard_link(dir.join("t.png"), dir.join("linked-t.png")).unwrap();
    let mut child = Command::new(TSLC)
        .args(["watch", &s(&scene), "-o", &s(&dir.join("linked-t.png")), "--res", "8x8", "--spp", "1"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (lines, done) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(stderr).lines().map_while(Result::ok) {
            if lines.send(line).is_err() {
                break;
            }
        }
    });
    let mut seen = String::new();
    let refused = loop {
        match done.recv_timeout(Duration::from_secs(60)) {
            Ok(line) => {
                seen += &line;
                seen.push('\n');
                if line.contains("cannot write") {
                    break true;
                }
                if line.contains("wrote") {
                    break false;
                }
            }
            Err(_) => break false,
        }
    };
    let _ = child.kill();
    let _ = child.wait();
    assert!(refused && seen.contains("a texture"), "{seen}");
    assert_eq!(std::fs::read(dir.join("t.png")).unwrap(), texture);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn merging_onto_one_of_the_tiles_is_refused() {
    let dir = temp_dir("files-merge");
    let (t0, t1) = (dir.join("t0.exr"), dir.join("t1.exr"));
    write_tile(&t0, 0, 2);
    write_tile(&t1, 1, 2);
    symlink(&t1, dir.join("link.exr")).unwrap();
    std::fs::hard_link(&t0, dir.join("hard.exr")).unwrap();
    let before = snapshot(&dir);
    for output in [t0.clone(), t1.clone(), dir.join("link.exr"), dir.join("hard.exr"), dir.join("./x/../t1.exr")] {
        std::fs::create_dir_all(dir.join("x")).unwrap();
        let o = tslc(&["merge", "-o", &s(&output), &s(&t0), &s(&t1)]);
        let err = stderr(&o);
        assert!(!o.status.success() && err.contains("input tile") && err.contains("would overwrite"), "{err}");
        assert_eq!(snapshot(&dir), before, "{}", s(&output));
    }
    let o = tslc(&["merge", "-o", &s(&dir.join("full.exr")), &s(&t0), &s(&t1)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

const UNFORMATTED: &str = "float   f( ) {return 1;}\n";
const FORMATTED: &str = "float f() {\n    return 1;\n}\n";

#[test]
fn fmt_writes_through_links_to_the_file_and_leaves_the_links() {
    let dir = temp_dir("files-fmt-links");
    std::fs::create_dir_all(dir.join("real")).unwrap();
    std::fs::create_dir_all(dir.join("links")).unwrap();
    let file = dir.join("real/a.tsl");
    let (near, far) = (dir.join("links/near.tsl"), dir.join("links/far.tsl"));
    symlink("../real/a.tsl", &near).unwrap();
    symlink(&near, &far).unwrap();
    for link in [&near, &far] {
        std::fs::write(&file, UNFORMATTED).unwrap();
        let o = tslc(&["fmt", &s(link)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(std::fs::read_to_string(&file).unwrap(), FORMATTED, "{}", s(link));
        assert!(is_regular(&file));
    }
    assert!(is_link_to(&near, Path::new("../real/a.tsl")) && is_link_to(&far, &near));
    let names = |d: &str| -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir.join(d))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    assert_eq!((names("real"), names("links")), (vec!["a.tsl".into()], vec!["far.tsl".into(), "near.tsl".into()]));
    let _ = std::fs::remove_dir_all(&dir);
}

fn is_root() -> bool {
    std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0)
}

#[test]
fn fmt_keeps_the_mode_owner_group_and_hard_links_of_a_file() {
    let dir = temp_dir("files-fmt-mode");
    for bits in [0o640, 0o755, 0o600, 0o444, 0o660, 0o750] {
        let file = dir.join(format!("m{bits:o}.tsl"));
        std::fs::write(&file, UNFORMATTED).unwrap();
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(bits)).unwrap();
        let owner = if is_root() {
            std::os::unix::fs::chown(&file, Some(4242), Some(4343)).unwrap();
            (4242, 4343)
        } else {
            let m = std::fs::metadata(&file).unwrap();
            (m.uid(), m.gid())
        };
        let o = tslc(&["fmt", &s(&file)]);
        assert!(o.status.success(), "{}", stderr(&o));
        let m = std::fs::metadata(&file).unwrap();
        assert_eq!(std::fs::read_to_string(&file).unwrap(), FORMATTED);
        assert_eq!((m.mode() & 0o7777, m.uid(), m.gid()), (bits, owner.0, owner.1), "{bits:o}");
    }
    // Hard links stay one file.
    let (a, b) = (dir.join("a.tsl"), dir.join("b.tsl"));
    std::fs::write(&a, UNFORMATTED).unwrap();
    std::fs::hard_link(&a, &b).unwrap();
    let o = tslc(&["fmt", &s(&a)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&b).unwrap(), FORMATTED);
    assert_eq!(std::fs::metadata(&a).unwrap().ino(), std::fs::metadata(&b).unwrap().ino());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Under root only: another user (nobody) formats a file of a third
/// user's in a shared folder it may write to. A new file would be
/// nobody's: the file is rewritten in place instead, and keeps its owner.
#[test]
fn fmt_in_a_shared_folder_never_gives_a_file_another_owner() {
    if !is_root() || !Path::new("/usr/bin/setpriv").exists() {
        eprintln!("skipped: needs root and setpriv to act as two users");
        return;
    }
    let dir = temp_dir("files-fmt-shared");
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
    let file = dir.join("shared.tsl");
    std::fs::write(&file, UNFORMATTED).unwrap();
    std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o666)).unwrap();
    std::os::unix::fs::chown(&file, Some(4242), Some(4343)).unwrap();
    let inode = std::fs::metadata(&file).unwrap().ino();
    let mut command = Command::new("setpriv");
    command.args(["--reuid=65534", "--regid=65534", "--clear-groups", TSLC, "fmt", &s(&file)]);
    let o = run(command);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = std::fs::metadata(&file).unwrap();
    assert_eq!(std::fs::read_to_string(&file).unwrap(), FORMATTED);
    assert_eq!((m.uid(), m.gid(), m.mode() & 0o7777, m.ino()), (4242, 4343, 0o666, inode));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "a backup or temporary was left");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fmt_and_check_refuse_huge_and_special_files_at_once() {
    let dir = temp_dir("files-fmt-special");
    let huge = dir.join("huge.tsl");
    std::fs::File::create(&huge).unwrap().set_len(257 << 20).unwrap();
    let fifo = dir.join("pipe.tsl");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let zero = dir.join("zero.tsl");
    symlink("/dev/zero", &zero).unwrap();
    for (file, why) in [(&huge, "larger than 256 MiB"), (&fifo, "named pipe"), (&zero, "character device")] {
        for command in ["fmt", "check"] {
            let o = tslc(&[command, &s(file)]);
            let err = stderr(&o);
            assert!(o.status.code() == Some(1) && err.contains(why) && err.contains(&s(file)), "{command}: {err}");
        }
    }
    assert_eq!(std::fs::metadata(&huge).unwrap().len(), 257 << 20);
    // Standard input stops at the same bound.
    let mut command = Command::new("sh");
    command.arg("-c").arg("head -c 269484032 /dev/zero | exec \"$0\" fmt -").arg(TSLC);
    let o = run(command);
    assert!(o.status.code() == Some(1) && stderr(&o).contains("larger than 256 MiB"), "{}", stderr(&o));
    // A walk takes regular files only: the FIFO and the link are not read.
    std::fs::remove_file(&huge).unwrap();
    std::fs::write(dir.join("ok.tsl"), UNFORMATTED).unwrap();
    let o = tslc(&["fmt", &s(&dir)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(dir.join("ok.tsl")).unwrap(), FORMATTED);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fmt_walks_real_directories_once_and_never_follows_links() {
    let dir = temp_dir("files-fmt-walk");
    let tree = dir.join("tree");
    std::fs::create_dir_all(tree.join("sub/deeper")).unwrap();
    std::fs::create_dir_all(dir.join("outside")).unwrap();
    for f in ["tree/a.tsl", "tree/sub/b.tsl", "tree/sub/deeper/c.tsl", "outside/o.tsl"] {
        std::fs::write(dir.join(f), UNFORMATTED).unwrap();
    }
    std::fs::write(tree.join("notes.txt"), UNFORMATTED).unwrap();
    // Loops of links, a link out of the tree, and links to files.
    symlink("..", tree.join("sub/up")).unwrap();
    symlink(".", tree.join("self")).unwrap();
    symlink("../../tree", tree.join("sub/deeper/root")).unwrap();
    symlink("../outside", tree.join("out")).unwrap();
    symlink("sub/b.tsl", tree.join("link.tsl")).unwrap();
    symlink("../outside/o.tsl", tree.join("o.tsl")).unwrap();
    let a = s(&tree.join("a.tsl"));
    // The tree, and a file in it named again: each file once.
    let o = tslc(&["fmt", "--check", &s(&tree), &a]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let mut headers: Vec<&str> = stdout.lines().filter_map(|l| l.strip_prefix("--- ")).collect();
    headers.sort();
    let expected = [a.clone(), s(&tree.join("sub/b.tsl")), s(&tree.join("sub/deeper/c.tsl"))];
    assert_eq!(headers, expected, "{stdout}");
    let o = tslc(&["fmt", &s(&tree)]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["tree/a.tsl", "tree/sub/b.tsl", "tree/sub/deeper/c.tsl"] {
        assert_eq!(std::fs::read_to_string(dir.join(f)).unwrap(), FORMATTED, "{f}");
    }
    assert_eq!(std::fs::read_to_string(dir.join("outside/o.tsl")).unwrap(), UNFORMATTED);
    assert!(is_link_to(&tree.join("link.tsl"), Path::new("sub/b.tsl")));
    // A link named on the command line is followed.
    let o = tslc(&["fmt", &s(&tree.join("o.tsl"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(dir.join("outside/o.tsl")).unwrap(), FORMATTED);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fmt_reports_a_directory_it_cannot_read_and_formats_the_rest() {
    let dir = temp_dir("files-fmt-unreadable");
    std::fs::create_dir_all(dir.join("locked")).unwrap();
    std::fs::write(dir.join("locked/hidden.tsl"), UNFORMATTED).unwrap();
    std::fs::write(dir.join("open.tsl"), UNFORMATTED).unwrap();
    std::fs::set_permissions(dir.join("locked"), std::fs::Permissions::from_mode(0o000)).unwrap();
    // Root reads any directory: act as nobody, for whom the rest is open.
    let o = if is_root() {
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o777)).unwrap();
        std::fs::set_permissions(dir.join("open.tsl"), std::fs::Permissions::from_mode(0o666)).unwrap();
        let mut command = Command::new("setpriv");
        command.args(["--reuid=65534", "--regid=65534", "--clear-groups", TSLC, "fmt", &s(&dir)]);
        run(command)
    } else {
        tslc(&["fmt", &s(&dir)])
    };
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot read the directory") && err.contains(&s(&dir.join("locked"))), "{err}");
    assert_eq!(std::fs::read_to_string(dir.join("open.tsl")).unwrap(), FORMATTED);
    std::fs::set_permissions(dir.join("locked"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
