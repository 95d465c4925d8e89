//! Files from outside the program, read as hostile input. EXR headers
//! whose claims lie (windows, frames, tiles, tile counts, channels, parts,
//! offset tables, headers without end) are refused by `tslc info`,
//! `tslc merge` and the texture loader before anything is allocated by
//! them; header strings and file names reach the terminal escaped; and
//! the files a scene names (meshes, environment images, textures, EXR
//! parts) are regular files of bounded size: a FIFO or a link to a device
//! is refused without blocking, a mesh's lines are bounded.

mod common;

use common::{stderr, temp_dir, tslc};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;
use tsl::image_io::{self, Metadata, RenderedImage};

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// Runs `tslc` with at most 1 GiB of address space: believing any claim
/// below would need several times that, and abort instead of answering.
fn tslc_in_1_gib(args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_tslc"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .expect("tslc runs")
}

/// Tile `index` of 2 of an 8 x 8 image with every AOV layer (11
/// channels), as `tslc render --tile index/2 --aov` writes it.
fn write_tile(path: &Path, index: u32, metadata: &mut Metadata) {
    let n = 8 * 4;
    let image = RenderedImage {
        full_width: 8,
        full_height: 8,
        x0: 0,
        y0: 4 * index,
        width: 8,
        height: 4,
        color: vec![[0.5, 0.25, 0.125]; n],
        albedo: Some(vec![[0.5; 3]; n]),
        normal: Some(vec![[0.0, 1.0, 0.0]; n]),
        depth: Some(vec![2.0; n]),
        object: Some(vec![0; n]),
    };
    metadata.set_text(image_io::SOFTWARE, "tslc test").set_int("tsl:tile", index as i32).set_int("tsl:tiles", 2);
    image_io::write_image_with(path, &image, metadata).unwrap();
}

/// A single-part EXR as its header's attributes (name, type, value) and
/// the bytes after the header (offset table and blocks), to be patched.
struct Exr {
    attributes: Vec<(String, String, Vec<u8>)>,
    rest: Vec<u8>,
}

impl Exr {
    fn read(path: &Path) -> Exr {
        let bytes = std::fs::read(path).unwrap();
        let c_string = |at: usize| {
            let end = at + bytes[at..].iter().position(|&b| b == 0).unwrap();
            (String::from_utf8(bytes[at..end].to_vec()).unwrap(), end + 1)
        };
        let mut at = 8;
        let mut attributes = Vec::new();
        while bytes[at] != 0 {
            let (name, next) = c_string(at);
            let (kind, next) = c_string(next);
            let size = i32::from_le_bytes(bytes[next..next + 4].try_into().unwrap()) as usize;
            attributes.push((name, kind, bytes[next + 4..next + 4 + size].to_vec()));
            at = next + 4 + size;
        }
        Exr { attributes, rest: bytes[at + 1..].to_vec() }
    }

    fn set(&mut self, name: &str, kind: &str, value: Vec<u8>) -> &mut Exr {
        match self.attributes.iter_mut().find(|a| a.0 == name) {
            Some(a) => (a.1, a.2) = (kind.into(), value),
            None => self.attributes.push((name.into(), kind.into(), value)),
        }
        self
    }

    fn set_int(&mut self, name: &str, value: i32) -> &mut Exr {
        self.set(name, "int", value.to_le_bytes().to_vec())
    }

    /// A window of `w` x `h` pixels at the origin.
    fn set_window(&mut self, name: &str, w: i32, h: i32) -> &mut Exr {
        self.set(name, "box2i", [0, 0, w - 1, h - 1].iter().flat_map(|v: &i32| v.to_le_bytes()).collect())
    }

    fn write(&self, path: &Path) {
        let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 2, 0, 0];
        for (name, kind, value) in &self.attributes {
            bytes.extend(name.as_bytes());
            bytes.push(0);
            bytes.extend(kind.as_bytes());
            bytes.push(0);
            bytes.extend((value.len() as i32).to_le_bytes());
            bytes.extend(value);
        }
        bytes.push(0);
        bytes.extend(&self.rest);
        std::fs::write(path, bytes).unwrap();
    }
}

/// A channel list of `n` float channels, in name order as the format
/// wants.
fn channel_list(n: usize) -> Vec<u8> {
    let mut value = Vec::new();
    for k in 0..n {
        value.extend(format!("c{k:05}").as_bytes());
        value.push(0);
        value.extend(2i32.to_le_bytes()); // FLOAT
        value.extend([0, 0, 0, 0]); // pLinear and reserved
        value.extend([1i32.to_le_bytes(), 1i32.to_le_bytes()].concat()); // sampling
    }
    value.push(0);
    value
}

/// An EXR of `parts` one-pixel scan-line parts (headers only).
fn many_parts(path: &Path, parts: usize) {
    let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 0x10, 0, 0];
    let attribute = |bytes: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]| {
        bytes.extend(name.as_bytes());
        bytes.push(0);
        bytes.extend(kind.as_bytes());
        bytes.push(0);
        bytes.extend((value.len() as i32).to_le_bytes());
        bytes.extend(value);
    };
    let window: Vec<u8> = [0i32, 0, 0, 0].iter().flat_map(|v| v.to_le_bytes()).collect();
    for k in 0..parts {
        attribute(&mut bytes, "channels", "chlist", &channel_list(1));
        attribute(&mut bytes, "compression", "compression", &[0]);
        attribute(&mut bytes, "dataWindow", "box2i", &window);
        attribute(&mut bytes, "displayWindow", "box2i", &window);
        attribute(&mut bytes, "lineOrder", "lineOrder", &[0]);
        attribute(&mut bytes, "name", "string", format!("part{k}").as_bytes());
        attribute(&mut bytes, "type", "string", b"scanlineimage");
        attribute(&mut bytes, "chunkCount", "int", &1i32.to_le_bytes());
        bytes.push(0);
    }
    bytes.push(0);
    bytes.extend(vec![0; parts * 8]);
    std::fs::write(path, bytes).unwrap();
}

/// Every lie, as (file name, what the refusal quotes): each written by
/// patching a valid tile, its pair tile 1 beside it.
fn lying_files(dir: &Path) -> (PathBuf, Vec<(PathBuf, &'static str)>) {
    let (good, other) = (dir.join("tile0.exr"), dir.join("tile1.exr"));
    write_tile(&good, 0, &mut Metadata::default());
    write_tile(&other, 1, &mut Metadata::default());
    let patched = |name: &str, patch: &dyn Fn(&mut Exr)| {
        let mut exr = Exr::read(&good);
        patch(&mut exr);
        let path = dir.join(name);
        exr.write(&path);
        path
    };
    let lies: Vec<(PathBuf, &str)> = vec![
        // 64 x 64 tiles: 313 x 313 blocks, as the crate counts them.
        (
            patched("window.exr", &|e| {
                e.set_window("dataWindow", 20000, 20000).set_window("displayWindow", 20000, 20000);
                e.set_int("chunkCount", 313 * 313);
            }),
            "claims a 20000 x 20000 data window",
        ),
        (
            patched("wide.exr", &|e| {
                e.set_window("dataWindow", 70000, 1).set_window("displayWindow", 70000, 1);
                e.set_int("chunkCount", 1094);
            }),
            "claims a 70000 x 1 data window; an image is at most 65536 pixels a side",
        ),
        (
            patched("frame.exr", &|e| {
                e.set_window("displayWindow", 65536, 65536);
            }),
            "65536 x 65536 display window",
        ),
        (
            patched("tiles.exr", &|e| {
                e.set(
                    "tiles",
                    "tiledesc",
                    [65536u32.to_le_bytes(), 65536u32.to_le_bytes()].concat().into_iter().chain([0]).collect(),
                );
            }),
            "claims 65536 x 65536 tiles of 44 bytes a pixel",
        ),
        (
            patched("decoded.exr", &|e| {
                e.set_window("dataWindow", 16000, 8000).set_window("displayWindow", 16000, 8000);
                e.set_int("chunkCount", 250 * 125);
            }),
            "which would take 5.2 GiB decoded, more than the 4 GiB an image may take",
        ),
        (
            patched("table.exr", &|e| {
                e.set_window("dataWindow", 4096, 4096).set_window("displayWindow", 4096, 4096);
                e.set_int("chunkCount", 64 * 64);
            }),
            "claims 4096 blocks of pixels, but at",
        ),
        (
            patched("channels.exr", &|e| {
                e.set("channels", "chlist", channel_list(1100));
            }),
            "claims 1100 channels",
        ),
        (
            patched("endless.exr", &|e| {
                e.set("tsl:junk", "string", vec![b'x'; 17 << 20]);
            }),
            "its header does not end within 16 MiB",
        ),
    ];
    let parts = dir.join("parts.exr");
    many_parts(&parts, 300);
    let mut lies = lies;
    lies.push((parts, "it has 300 parts; at most 256 are read"));
    (other, lies)
}

#[test]
fn lying_exr_headers_are_refused_by_info_and_merge_before_anything_is_allocated() {
    let dir = temp_dir("exr-lies");
    let (other, lies) = lying_files(&dir);
    for (path, claim) in &lies {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let e = image_io::read_exr_header(path).unwrap_err();
        assert!(e.contains(claim) && e.contains(&name), "{name}: {e}");
        let e = image_io::merge(&[path.clone(), other.clone()]).unwrap_err();
        assert!(e.contains(claim), "merge {name}: {e}");
        // The part may come second: its header is still read before any
        // pixel of the first.
        let e = image_io::merge(&[other.clone(), path.clone()]).unwrap_err();
        assert!(e.contains(claim), "merge {name} second: {e}");
        for args in [vec!["info", path.to_str().unwrap()], vec!["info", "--json", path.to_str().unwrap()]] {
            let o = tslc_in_1_gib(&args);
            assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
            assert!(stderr(&o).contains(claim) && stderr(&o).contains(&name), "{args:?}: {}", stderr(&o));
        }
        let out = s(&dir.join("merged.exr"));
        let o = tslc_in_1_gib(&["merge", path.to_str().unwrap(), other.to_str().unwrap(), "-o", &out]);
        assert_eq!(o.status.code(), Some(1), "merge {name}: {}", stderr(&o));
        assert!(stderr(&o).contains(claim), "merge {name}: {}", stderr(&o));
        assert!(!Path::new(&out).exists());
    }
    // The two honest tiles still merge, in that memory.
    let good = dir.join("tile0.exr");
    let out = s(&dir.join("merged.exr"));
    let o = tslc_in_1_gib(&["merge", good.to_str().unwrap(), other.to_str().unwrap(), "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn lying_exr_textures_are_refused_before_their_pixels_are_allocated() {
    let dir = temp_dir("exr-texture-lies");
    let (_, lies) = lying_files(&dir);
    let textures = tsl::texture::TextureManager::new();
    for (path, claim) in &lies {
        let loaded = textures.load(path, tsl::texture::Encoding::Raw).map(|_| ());
        // A picture's side is bounded tighter than a render's, and its
        // display window is not used.
        let claim = match *claim {
            "claims a 20000 x 20000 data window" => "claims a 20000 x 20000 data window; an image is at most 16384",
            "claims a 70000 x 1 data window; an image is at most 65536 pixels a side" => "claims a 70000 x 1",
            "65536 x 65536 display window" => {
                assert!(loaded.is_ok(), "{loaded:?}");
                continue;
            }
            claim => claim,
        };
        assert!(loaded.as_ref().is_err_and(|e| e.contains(claim)), "{}: {loaded:?}", path.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Tile counts a frame 8 rows high cannot be cut into, each claimed by
/// both tiles (so they agree): refused before a table of them is made.
#[test]
fn impossible_tile_counts_are_refused_by_merge() {
    let dir = temp_dir("exr-tile-counts");
    for count in [i32::MAX, 9, 0, -1] {
        let paths: Vec<PathBuf> = (0..2)
            .map(|k| {
                let path = dir.join(format!("tile{k}.exr"));
                write_tile(&path, k, &mut Metadata::default());
                let mut exr = Exr::read(&path);
                exr.set_int("tsl:tiles", count);
                exr.write(&path);
                path
            })
            .collect();
        let claim = format!("says it is one of {count} tiles, but the 8x8 image is cut into 1 to 8 tiles");
        let e = image_io::merge(&paths).unwrap_err();
        assert!(e.contains(&claim), "{count}: {e}");
        let out = s(&dir.join("out.exr"));
        let o = tslc_in_1_gib(&["merge", paths[0].to_str().unwrap(), paths[1].to_str().unwrap(), "-o", &out]);
        assert_eq!(o.status.code(), Some(1), "{count}: {}", stderr(&o));
        assert!(stderr(&o).contains(&claim), "{count}: {}", stderr(&o));
        // `tslc info` shows the claim: it allocates nothing by it.
        let o = tslc_in_1_gib(&["info", paths[0].to_str().unwrap()]);
        assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains(&count.to_string()));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bytes a terminal would act on: C0 controls, DEL, and C1 (as UTF-8).
fn terminal_controls(bytes: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(bytes);
    // A tab or a line break moves the cursor, nothing more.
    text.chars().filter(|c| c.is_control() && !matches!(c, '\n' | '\t')).map(|c| format!("{:?}", c)).collect()
}

#[test]
fn header_strings_and_file_names_reach_the_terminal_escaped() {
    let dir = temp_dir("exr-escapes");
    let mut meta = Metadata::default();
    meta.set_text("tsl:scene", "shot\x1b]0;pwned\x07.tsl")
        .set_text("tsl:integrator", "pa\x1b[2Jth")
        .set_text("tsl:note\x1b[31m", "\u{9b}31mred\u{7f}\ttab\r\nline");
    let tile = dir.join("tile\x1b[31m0.exr");
    write_tile(&tile, 0, &mut meta);
    let o = tslc(&["info", tile.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(terminal_controls(&o.stdout), Vec::<String>::new());
    let text = String::from_utf8_lossy(&o.stdout);
    for escaped in ["shot␛]0;pwned␇.tsl", "pa␛[2Jth", "tsl:note␛[31m", "�31mred␡\ttab␍␊line", "tile␛[31m0.exr"]
    {
        assert!(text.contains(escaped), "{escaped}: {text}");
    }
    // JSON escapes every control character and keeps the value.
    let o = tslc(&["info", "--json", tile.to_str().unwrap()]);
    assert_eq!(terminal_controls(&o.stdout), Vec::<String>::new());
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["attributes"]["tsl:note\x1b[31m"].as_str(), Some("\u{9b}31mred\u{7f}\ttab\r\nline"));
    assert_eq!(json["file"].as_str(), Some(tile.to_str().unwrap()));
    // Merge quotes the values that disagree, and the file names.
    let other = dir.join("tile1.exr");
    let mut plain = Metadata::default();
    plain.set_text("tsl:integrator", "path");
    write_tile(&other, 1, &mut plain);
    let out = s(&dir.join("out.exr"));
    let o = tslc(&["merge", tile.to_str().unwrap(), other.to_str().unwrap(), "-o", &out]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(terminal_controls(&o.stderr), Vec::<String>::new(), "{}", stderr(&o));
    assert!(stderr(&o).contains("`pa␛[2Jth`") && stderr(&o).contains("tile␛[31m0.exr"), "{}", stderr(&o));
    // A file name that is not an EXR at all, in `info`'s error.
    let junk = dir.join("junk\x1b[5m.exr");
    std::fs::write(&junk, b"\x76\x2f\x31\x01\x02\x00\x00\x00bad\x1b[2J\x00").unwrap();
    let o = tslc(&["info", junk.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(terminal_controls(&o.stderr), Vec::<String>::new(), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs `f` on another thread and waits at most a minute for it: a read
/// that blocks (a FIFO no one writes) fails the test instead of hanging.
fn within_a_minute<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || send.send(f()));
    receive.recv_timeout(Duration::from_secs(60)).unwrap_or_else(|_| panic!("{what} did not finish"))
}

/// The diagnostics of checking `src` (paths in it absolute).
fn check(what: &str, src: String) -> String {
    within_a_minute(what, move || {
        let checked = tsl::check_source("scene.tsl", &src, &tsl::LoadOptions::default());
        checked.render_diagnostics()
    })
}

/// The special files a scene may be pointed at: a FIFO (opening it for
/// reading would wait for a writer), a link to `/dev/zero` (endless), a
/// directory; with the words each is refused in.
fn special_files(dir: &Path, ext: &str) -> Vec<(PathBuf, &'static str)> {
    let mut out = Vec::new();
    let fifo = dir.join(format!("pipe.{ext}"));
    if Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        out.push((fifo, "FIFO"));
    }
    if Path::new("/dev/zero").exists() {
        let zero = dir.join(format!("zero.{ext}"));
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        out.push((zero, "character device"));
    }
    let folder = dir.join(format!("folder.{ext}"));
    std::fs::create_dir(&folder).unwrap();
    out.push((folder, "directory"));
    out
}

const CAMERA: &str = "camera { from (0, 1, -4); to (0, 0, 0); }";

#[test]
fn meshes_and_environment_images_that_are_special_files_are_refused_without_blocking() {
    let dir = temp_dir("special-scene-files");
    for (mesh, words) in special_files(&dir, "obj") {
        let src = format!(r#"scene {{ {CAMERA} object mesh {{ file "{}"; material lambert; }} }}"#, s(&mesh));
        let column = src.find("\"/").unwrap() + 1;
        let e = check("a mesh", src);
        assert!(e.contains(words) && e.contains(&format!("scene.tsl:1:{column}")), "{}: {e}", mesh.display());
    }
    for ext in ["exr", "hdr", "png"] {
        for (sky, words) in special_files(&dir, ext) {
            let src = format!(r#"scene {{ {CAMERA} light environment {{ file "{}"; }} }}"#, s(&sky));
            let column = src.find("\"/").unwrap() + 1;
            let e = check("an environment image", src);
            // A link to /dev/zero named .png is refused by its type too.
            assert!(e.contains(words) && e.contains(&format!("scene.tsl:1:{column}")), "{}: {e}", sky.display());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn textures_and_exr_parts_that_are_special_files_are_refused_without_blocking() {
    let dir = temp_dir("special-images");
    for ext in ["png", "exr", "jpg"] {
        for (image, words) in special_files(&dir, ext) {
            let loaded = within_a_minute("a texture", {
                let image = image.clone();
                move || tsl::texture::TextureManager::new().load(&image, tsl::texture::Encoding::Srgb).map(|_| ())
            });
            // Followed to /dev/zero, the canonical path has no image
            // extension: refused as a format before it is opened.
            let texture_words = if words == "character device" { "not an image format" } else { words };
            assert!(loaded.as_ref().is_err_and(|e| e.contains(texture_words)), "{}: {loaded:?}", image.display());
            if ext == "exr" {
                let path = s(&image);
                let o = within_a_minute("tslc info", move || tslc(&["info", &path]));
                assert!(o.status.code() == Some(1) && stderr(&o).contains(words), "{}", stderr(&o));
                let out = s(&dir.join("merged.exr"));
                let path = s(&image);
                let o = within_a_minute("tslc merge", move || tslc(&["merge", &path, "-o", &out]));
                assert!(o.status.code() == Some(1) && stderr(&o).contains(words), "{}", stderr(&o));
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_mesh_is_read_within_its_size_and_line_bounds() {
    let dir = temp_dir("mesh-bounds");
    let mesh_error = |name: &str, text: Option<&[u8]>, len: Option<u64>| {
        let path = dir.join(name);
        let file = std::fs::File::create(&path).unwrap();
        if let Some(text) = text {
            std::io::Write::write_all(&mut &file, text).unwrap();
        }
        if let Some(len) = len {
            // Sparse: no disk is used.
            file.set_len(len).unwrap();
        }
        let src = format!(r#"scene {{ {CAMERA} object mesh {{ file "{}"; material lambert; }} }}"#, s(&path));
        check(name, src)
    };
    let line = tsl::scene::MAX_MESH_LINE_BYTES as usize;
    // A file that never ends a line, from its first line or later.
    let e = mesh_error("endless.obj", Some(&vec![b'v'; line + 10]), None);
    assert!(e.contains("line 1 is longer than 1 MiB"), "{e}");
    let mut late = b"v 0 0 0\nv 1 0 0\n# ".to_vec();
    late.extend(vec![b'#'; line]);
    let e = mesh_error("late.obj", Some(&late), None);
    assert!(e.contains("line 3 is longer than 1 MiB"), "{e}");
    // A long comment line within the bound is read.
    let mut fine = b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# ".to_vec();
    fine.extend(vec![b'#'; line - 100]);
    fine.extend(b"\nf 1 2 3\n");
    let e = mesh_error("fine.obj", Some(&fine), None);
    assert!(!e.contains("error"), "{e}");
    // Beyond the size bound, refused before it is read.
    let e = mesh_error("huge.obj", Some(b"v 0 0 0\n"), Some(tsl::scene::MAX_MESH_BYTES + 1));
    assert!(e.contains("more than the 1 GiB a mesh may be"), "{e}");
    let sky = dir.join("huge.exr");
    std::fs::File::create(&sky).unwrap().set_len(image_io::MAX_IMAGE_FILE_BYTES + 1).unwrap();
    let src = format!(r#"scene {{ {CAMERA} light environment {{ file "{}"; }} }}"#, s(&sky));
    let e = check("a huge environment image", src);
    assert!(e.contains("more than the 8 GiB an image file may be"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
