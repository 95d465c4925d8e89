use super::*;
use crate::test_support::temp_dir;

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

#[cfg(unix)]
#[test]
fn a_temporary_is_a_new_regular_file_with_a_random_name_and_is_the_file_written() {
    let dir = temp_dir("files-random");
    let target = dir.join("out.png");
    let mut seen = std::collections::HashSet::new();
    for k in 0..40 {
        atomic_write(&target, |file| {
            let entries: Vec<PathBuf> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
            let temporaries: Vec<&PathBuf> = entries.iter().filter(|p| is_temporary_for(&target, p)).collect();
            assert_eq!(temporaries.len(), 1, "{entries:?}");
            let tmp = temporaries[0];
            let name = tmp.file_name().unwrap().to_string_lossy().into_owned();
            let random = name.strip_prefix(".out.png.tmp-").unwrap();
            assert_eq!(random.len(), TEMPORARY_RANDOM_CHARS, "{name}");
            assert!(!random.contains(&std::process::id().to_string()), "{name}");
            assert!(seen.insert(name.clone()), "{name} twice");
            // Created, not found: a regular file, and the very file we hold.
            assert!(std::fs::symlink_metadata(tmp).unwrap().file_type().is_file());
            assert_eq!(FileIdentity::of_entry(tmp), FileIdentity::of_open(file));
            assert!(TEMPORARIES.lock().unwrap().contains(tmp), "registered for the signal handler");
            std::io::Write::write_all(file, format!("image {k}").as_bytes()).map_err(|e| e.to_string())
        })
        .unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), format!("image {k}"));
        assert_eq!(names(&dir), ["out.png"]);
    }
    assert!(!TEMPORARIES.lock().unwrap().iter().any(|p| p.starts_with(&dir)));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_failed_write_keeps_the_target_and_leaves_no_temporary() {
    let dir = temp_dir("files-failed");
    let target = dir.join("keep.exr");
    std::fs::write(&target, "precious").unwrap();
    let e = atomic_write(&target, |file| {
        std::io::Write::write_all(file, b"half an ima").unwrap();
        Err("the encoder gave up".into())
    })
    .unwrap_err();
    assert_eq!(e, format!("cannot write {}: the encoder gave up", target.display()));
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "precious");
    assert_eq!(names(&dir), ["keep.exr"]);
    let missing = dir.join("no/such/out.png");
    let e = atomic_write(&missing, |_| Ok(())).unwrap_err();
    assert!(e.contains("does not exist") && e.contains("out.png"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn a_link_at_the_target_is_replaced_and_its_target_left_alone() {
    let dir = temp_dir("files-link-target");
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "not yours").unwrap();
    let target = dir.join("out.png");
    std::os::unix::fs::symlink(&victim, &target).unwrap();
    atomic_write(&target, |file| std::io::Write::write_all(file, b"image").map_err(|e| e.to_string())).unwrap();
    assert!(std::fs::symlink_metadata(&target).unwrap().file_type().is_file());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "image");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "not yours");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_probe_leaves_nothing_and_names_the_users_path() {
    let dir = temp_dir("files-probe");
    for k in 0..10 {
        check_writable(&dir.join(format!("out{k}.png"))).unwrap();
    }
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
    let e = check_writable(&dir.join("none/out.png")).unwrap_err();
    assert!(e.contains("none/out.png") && e.contains("does not exist"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn temporaries_are_recognised_by_target_directory_and_shape() {
    let target = Path::new("renders/out.png");
    let random = "aB3dE6gH9jK1";
    assert!(is_temporary_for(target, &Path::new("renders").join(format!(".out.png.tmp-{random}"))));
    for other in [
        format!("renders/.out.png.tmp-{random}x"),
        format!("renders/.out.png.tmp-{}", &random[1..]),
        "renders/.out.png.tmp-aB3dE6gH9j-1".to_string(),
        format!("elsewhere/.out.png.tmp-{random}"),
        format!("renders/.other.png.tmp-{random}"),
        "renders/out.png".to_string(),
    ] {
        assert!(!is_temporary_for(target, Path::new(&other)), "{other}");
    }
    assert!(is_temporary_for(Path::new("out.png"), Path::new(&format!("./.out.png.tmp-{random}"))));
}

#[cfg(unix)]
#[test]
fn identity_sees_through_spellings_and_links() {
    let dir = temp_dir("files-identity");
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    let file = dir.join("a.png");
    std::fs::write(&file, "a").unwrap();
    std::fs::write(dir.join("b.png"), "a").unwrap();
    std::fs::hard_link(&file, dir.join("hard.png")).unwrap();
    std::os::unix::fs::symlink(&file, dir.join("soft.png")).unwrap();
    std::os::unix::fs::symlink(&dir, dir.join("sub/up")).unwrap();
    let id = FileIdentity::of(&file).unwrap();
    for same in ["hard.png", "soft.png", "sub/../a.png", "sub/up/a.png", "./sub/up/sub/up/hard.png"] {
        assert_eq!(FileIdentity::of(&dir.join(same)).as_ref(), Some(&id), "{same}");
        assert!(FileIdentity::all_of(&dir.join(same)).contains(&id), "{same}");
    }
    assert_ne!(FileIdentity::of(&dir.join("b.png")).unwrap(), id, "the same bytes, another file");
    assert_eq!(FileIdentity::all_of(&file), std::slice::from_ref(&id));
    let soft = FileIdentity::all_of(&dir.join("soft.png"));
    assert_eq!((soft.len(), soft[1].clone()), (2, id), "the link's own and its target's");
    assert!(
        FileIdentity::all_of(&dir.join("none.png")).is_empty() && FileIdentity::of(&dir.join("none.png")).is_none()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[cfg(unix)]
mod replacing {
    use super::*;
    use std::os::unix::fs::{MetadataExt, PermissionsExt};

    fn mode(path: &Path) -> u32 {
        std::fs::metadata(path).unwrap().mode() & 0o7777
    }

    #[test]
    fn a_source_keeps_its_mode_and_a_link_stays_a_link_to_it() {
        let dir = temp_dir("files-replace-mode");
        std::fs::create_dir_all(dir.join("real")).unwrap();
        for (k, bits) in [0o640, 0o755, 0o600, 0o444, 0o664, 0o2750].into_iter().enumerate() {
            let file = dir.join(format!("real/f{k}.tsl"));
            std::fs::write(&file, "old").unwrap();
            std::fs::set_permissions(&file, std::fs::Permissions::from_mode(bits)).unwrap();
            // Named directly, and through a chain of two links in another
            // directory.
            let link1 = dir.join(format!("l{k}a.tsl"));
            let link2 = dir.join(format!("l{k}b.tsl"));
            std::os::unix::fs::symlink(&file, &link1).unwrap();
            std::os::unix::fs::symlink(&link1, &link2).unwrap();
            assert_eq!(replace_source(&file, b"old", b"new").unwrap(), Replaced::Renamed);
            assert_eq!((std::fs::read_to_string(&file).unwrap(), mode(&file)), ("new".into(), bits), "{bits:o}");
            assert_eq!(replace_source(&link2, b"new", b"newer").unwrap(), Replaced::Renamed);
            assert_eq!((std::fs::read_to_string(&file).unwrap(), mode(&file)), ("newer".into(), bits), "{bits:o}");
            assert_eq!(std::fs::read_link(&link2).unwrap(), link1);
            assert_eq!(std::fs::read_link(&link1).unwrap(), file);
        }
        let leftovers: Vec<String> = names(&dir.join("real")).into_iter().filter(|n| n.starts_with('.')).collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_source_with_hard_links_is_rewritten_in_place_for_every_name() {
        let dir = temp_dir("files-replace-links");
        let (a, b) = (dir.join("a.tsl"), dir.join("b.tsl"));
        std::fs::write(&a, "a long old text").unwrap();
        std::fs::hard_link(&a, &b).unwrap();
        let inode = std::fs::metadata(&a).unwrap().ino();
        assert_eq!(replace_source(&a, b"a long old text", b"short").unwrap(), Replaced::InPlace);
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "short");
        assert_eq!(std::fs::metadata(&a).unwrap().ino(), inode);
        assert_eq!(names(&dir), ["a.tsl", "b.tsl"], "the backup is removed");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn writing_in_place_keeps_the_inode_owner_and_mode() {
        let dir = temp_dir("files-in-place");
        let file = dir.join("shared.tsl");
        std::fs::write(&file, "old text that is longer").unwrap();
        std::fs::set_permissions(&file, std::fs::Permissions::from_mode(0o664)).unwrap();
        let before = std::fs::metadata(&file).unwrap();
        assert_eq!(
            replace::in_place(&file, &file, &before, b"old text that is longer", b"new").unwrap(),
            Replaced::InPlace
        );
        let after = std::fs::metadata(&file).unwrap();
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "new");
        assert_eq!(
            (after.ino(), after.uid(), after.gid(), after.mode()),
            (before.ino(), before.uid(), before.gid(), before.mode())
        );
        assert_eq!(names(&dir), ["shared.tsl"]);
        // A file swapped in after it was examined is not written.
        let other = dir.join("other.tsl");
        std::fs::write(&other, "other").unwrap();
        std::fs::rename(&other, &file).unwrap();
        let e = replace::in_place(&file, &file, &before, b"new", b"newer").unwrap_err();
        assert!(e.contains("replaced while being formatted"), "{e}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "other");
        assert_eq!(names(&dir), ["shared.tsl"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn what_is_not_a_regular_file_is_refused() {
        let dir = temp_dir("files-replace-special");
        let e = replace_source(&dir, b"", b"x").unwrap_err();
        assert!(e.contains("not a regular file"), "{e}");
        let e = replace_source(&dir.join("missing.tsl"), b"", b"x").unwrap_err();
        assert!(e.contains("missing.tsl"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
