use std::fs;
use std::path::{Path, PathBuf};

use super::*;

/// A fresh folder for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wins-io-safety-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn a_missing_path_resolves_through_its_existing_parent() {
    let dir = scratch("resolve");
    fs::create_dir_all(dir.join("a")).unwrap();
    let canonical = dir.canonicalize().unwrap();
    assert_eq!(
        resolve(&dir.join("a/./b/c")).unwrap(),
        canonical.join("a/b/c")
    );
    assert_eq!(
        resolve(&dir.join("a/x/../y")).unwrap(),
        canonical.join("a/y")
    );
    assert_eq!(resolve(&dir.join("a/../a")).unwrap(), canonical.join("a"));
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_same_file_is_refused_under_any_spelling() {
    let dir = scratch("same");
    let log = dir.join("log.dat");
    fs::write(&log, b"csi").unwrap();
    let err = refuse_same_file(&log, &dir.join("./log.dat")).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("log.dat") && text.contains("is the input"),
        "{text}"
    );
    #[cfg(unix)]
    {
        let link = dir.join("link.dat");
        std::os::unix::fs::symlink(&log, &link).unwrap();
        assert!(refuse_same_file(&log, &link).is_err(), "a symbolic link");
        let hard = dir.join("hard.dat");
        fs::hard_link(&log, &hard).unwrap();
        assert!(refuse_same_file(&log, &hard).is_err(), "a hard link");
    }
    refuse_same_file(&log, &dir.join("log.jsonl")).unwrap();
    refuse_same_file(&log, &dir.join("new/log.dat")).unwrap();
    assert_eq!(fs::read(&log).unwrap(), b"csi");
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_output_folder_on_inside_or_around_an_input_is_refused() {
    let dir = scratch("overlap");
    let data = dir.join("data");
    fs::create_dir_all(data.join("truth")).unwrap();
    let config = dir.join("my.toml");
    fs::write(&config, "").unwrap();
    let inputs = [data.as_path(), config.as_path()];
    for out in [
        data.clone(),
        data.join("truth"),
        data.join("new/deeper"),
        dir.join("data/../data/run"),
        dir.clone(),
        config.clone(),
    ] {
        let err = refuse_overlap(&out, &inputs).expect_err(&out.display().to_string());
        let text = err.to_string();
        assert!(text.contains(&out.display().to_string()), "{text}");
    }
    refuse_overlap(&dir.join("run"), &inputs).unwrap();
    refuse_overlap(&dir.join("data-run"), &inputs).unwrap();
    fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_folder_under_a_regular_file_is_not_writable() {
    let dir = scratch("writable");
    let file = dir.join("file");
    fs::write(&file, "").unwrap();
    let err = check_writable_dir(&file.join("out")).unwrap_err();
    assert!(matches!(err, OutputError::NotWritable { .. }), "{err}");
    check_writable_dir(&dir.join("out/deeper")).unwrap();
    assert_eq!(
        fs::read_dir(dir.join("out/deeper")).unwrap().count(),
        0,
        "probe removed"
    );
    fs::remove_dir_all(&dir).unwrap();
}

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn a_failed_write_keeps_the_previous_file_and_leaves_no_temporary() {
    let dir = scratch("atomic");
    let path = dir.join("report.txt");
    write_atomically(&path, |w| w.write_all(b"first")).unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"first");
    let err = write_atomically(&path, |w| {
        w.write_all(b"half")?;
        Err(io::Error::other("disk full"))
    })
    .unwrap_err();
    assert_eq!(err.to_string(), "disk full");
    assert_eq!(fs::read(&path).unwrap(), b"first");
    assert_eq!(names(&dir), ["report.txt"]);
    replace_atomically(&path, |temp| {
        assert!(temp.to_string_lossy().ends_with("report.txt"), "{temp:?}");
        fs::write(temp, "second")
    })
    .unwrap();
    assert_eq!(fs::read(&path).unwrap(), b"second");
    assert_eq!(names(&dir), ["report.txt"]);
    write_atomically_unsynced(&path, |w| w.write_all(b"third")).unwrap();
    let err = write_atomically_unsynced(&path, |_| Err(io::Error::other("no"))).unwrap_err();
    assert_eq!(err.to_string(), "no");
    assert_eq!(fs::read(&path).unwrap(), b"third");
    assert_eq!(names(&dir), ["report.txt"]);
    fs::remove_dir_all(&dir).unwrap();
}
