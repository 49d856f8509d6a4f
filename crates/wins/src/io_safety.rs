//! Outputs that cannot destroy inputs or leave half files: path comparison through canonical
//! paths ([`resolve`]), the refusals of an output onto an input ([`refuse_same_file`],
//! [`refuse_overlap`]), a writability probe ([`check_writable_dir`]), atomic replacement of a
//! file ([`write_atomically`], [`replace_atomically`], [`write_atomically_unsynced`]) and a
//! writer of streamed files that hands them whole lines and records only ([`WholeRecords`]).

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Read, Write};
use std::path::{Component, Path, PathBuf};

mod whole;

pub use whole::{HAND_OFF_BYTES, WholeRecords};

/// Prefix of the temporary files [`replace_atomically`] writes next to their target.
pub const TEMP_PREFIX: &str = ".wins-tmp-";

/// Why an output cannot be written where it was asked.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output file is the input file.
    #[error("the output {output} is the input {input}: choose another output file")]
    SameFile {
        /// The input, as given.
        input: PathBuf,
        /// The output, as given.
        output: PathBuf,
    },
    /// The output folder is, holds or lies inside an input.
    #[error(
        "the output folder {out} would overlap the input {input} (the same path, inside it or \
         holding it): choose a folder outside the dataset and the input files"
    )]
    OntoInput {
        /// The output folder, as given.
        out: PathBuf,
        /// The input it overlaps, as given.
        input: PathBuf,
    },
    /// The output folder cannot be created or written.
    #[error("the output folder {path} is not writable: {source}")]
    NotWritable {
        /// The folder.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
    /// The output folder holds files and no run manifest.
    #[error(
        "{path} is not a wins run directory (no {manifest}) and not empty: choose a new or empty \
         folder"
    )]
    NotARunDir {
        /// The folder.
        path: PathBuf,
        /// The manifest's file name.
        manifest: &'static str,
    },
    /// The manifest of a previous run cannot be read.
    #[error("{path}: not a readable run manifest ({reason}): choose a new or empty folder")]
    BadManifest {
        /// The manifest.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// Another I/O failure on a path.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: io::Error,
    },
}

impl OutputError {
    /// An [`OutputError::Io`] on `path`.
    pub fn io(path: &Path) -> impl FnOnce(io::Error) -> Self + '_ {
        move |source| Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Largest text file read whole (a manifest, a calibration, a configuration), bytes.
pub const MAX_TEXT_FILE_BYTES: u64 = 16 << 20;

/// Opens an input file, refusing anything but a regular file: a device (`/dev/zero`), a FIFO or
/// a folder would be read without end, or block.
pub fn open_regular(path: &Path) -> io::Result<File> {
    let not_regular = || {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "not a regular file (a device, a FIFO or a folder): inputs must be regular files",
        )
    };
    // The type is checked before opening: opening a FIFO blocks until a writer comes.
    if !fs::metadata(path)?.is_file() {
        return Err(not_regular());
    }
    let file = File::open(path)?;
    if !file.metadata()?.is_file() {
        return Err(not_regular());
    }
    Ok(file)
}

/// Reads a whole text file that must be a regular file of at most [`MAX_TEXT_FILE_BYTES`].
pub fn read_text(path: &Path) -> io::Result<String> {
    let file = open_regular(path)?;
    let len = file.metadata()?.len();
    if len > MAX_TEXT_FILE_BYTES {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{len} bytes; a settings file holds at most {MAX_TEXT_FILE_BYTES}"),
        ));
    }
    let mut text = String::new();
    file.take(MAX_TEXT_FILE_BYTES).read_to_string(&mut text)?;
    Ok(text)
}

/// `path` made absolute and canonical (symbolic links, `.` and `..` resolved). A path that does
/// not exist yet is resolved through its longest existing ancestor, the rest appended as written
/// (`..` in the rest removes a component).
pub fn resolve(path: &Path) -> io::Result<PathBuf> {
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()?.join(path)
    };
    let components: Vec<Component<'_>> = absolute.components().collect();
    for k in (1..=components.len()).rev() {
        let prefix: PathBuf = components[..k].iter().collect();
        let Ok(mut out) = prefix.canonicalize() else {
            continue;
        };
        for c in &components[k..] {
            match c {
                Component::ParentDir => {
                    out.pop();
                }
                Component::Normal(name) => out.push(name),
                Component::CurDir | Component::RootDir | Component::Prefix(_) => {}
            }
        }
        return Ok(out);
    }
    Err(io::Error::new(
        io::ErrorKind::NotFound,
        format!("no part of {} exists", path.display()),
    ))
}

/// `resolve`, with the path in the error.
fn resolved(path: &Path) -> Result<PathBuf, OutputError> {
    resolve(path).map_err(OutputError::io(path))
}

/// Refuses an `output` file that is the `input` file (the same canonical path or, on Unix, the
/// same file through another link): writing it would empty the input before it is read.
pub fn refuse_same_file(input: &Path, output: &Path) -> Result<(), OutputError> {
    let same = resolved(input)? == resolved(output)? || same_inode(input, output);
    if same {
        return Err(OutputError::SameFile {
            input: input.to_path_buf(),
            output: output.to_path_buf(),
        });
    }
    Ok(())
}

#[cfg(unix)]
fn same_inode(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_inode(_: &Path, _: &Path) -> bool {
    false
}

/// Refuses an output folder `out` that is an input (file or folder), lies inside an input folder
/// or holds an input: files written into it, or a previous run's files removed from it, could
/// then replace or delete the input.
pub fn refuse_overlap(out: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    let out_resolved = resolved(out)?;
    for input in inputs {
        let input_resolved = resolved(input)?;
        if out_resolved.starts_with(&input_resolved) || input_resolved.starts_with(&out_resolved) {
            return Err(OutputError::OntoInput {
                out: out.to_path_buf(),
                input: input.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// Creates the folder `dir` (and its parents) and checks that a file can be created in it (a
/// probe file, removed at once).
pub fn check_writable_dir(dir: &Path) -> Result<(), OutputError> {
    let not_writable = |source| OutputError::NotWritable {
        path: dir.to_path_buf(),
        source,
    };
    fs::create_dir_all(dir).map_err(not_writable)?;
    let probe = dir.join(format!("{TEMP_PREFIX}probe-{}", std::process::id()));
    OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .open(&probe)
        .map_err(not_writable)?;
    fs::remove_file(&probe).map_err(not_writable)
}

/// The temporary file next to `path` that [`replace_atomically`] writes: hidden, and ending
/// with the target's own name so that a writer choosing its format by extension is not misled.
pub fn temp_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} names no file", path.display()),
        )
    })?;
    let mut temp = std::ffi::OsString::from(format!("{TEMP_PREFIX}{}-", std::process::id()));
    temp.push(name);
    Ok(path.with_file_name(temp))
}

/// Writes the file `path` through `create`, which is given a temporary path in the same folder
/// to write; the temporary file is then flushed to the disk and renamed onto `path`. A failure
/// or a crash leaves the previous `path` (or none), never a half-written one; on failure the
/// temporary file is removed.
pub fn replace_atomically(
    path: &Path,
    create: impl FnOnce(&Path) -> io::Result<()>,
) -> io::Result<()> {
    replace(path, true, create)
}

/// [`replace_atomically`], the temporary file renamed without waiting for the disk: for a file
/// rewritten every few seconds by a program that must not stall (`wins live`'s interim
/// `stats.json`). A killed process still leaves the previous file or the new one, whole; after
/// a power loss the new one may be missing or, on a file system that does not order a rename
/// after the data it replaces (ext4 does, for a rename over an existing file), empty.
pub fn write_atomically_unsynced(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    replace(path, false, |temp| write_buffered(temp, write))
}

/// [`replace_atomically`], the temporary file synced to the disk first when `sync`.
fn replace(
    path: &Path,
    sync: bool,
    create: impl FnOnce(&Path) -> io::Result<()>,
) -> io::Result<()> {
    let temp = temp_path(path)?;
    let done = create(&temp)
        .and_then(|()| match sync {
            true => OpenOptions::new().write(true).open(&temp)?.sync_all(),
            false => Ok(()),
        })
        .and_then(|()| fs::rename(&temp, path));
    if done.is_err() {
        // Nothing to do if it is already gone: the error that matters is `done`'s.
        let _ = fs::remove_file(&temp);
    }
    done
}

/// [`replace_atomically`] with a buffered writer: `write` fills the temporary file.
///
/// ```no_run
/// use std::io::Write;
/// wins::io_safety::write_atomically("out/report.txt".as_ref(), |w| writeln!(w, "ATE 0.2 m"))?;
/// # Ok::<(), std::io::Error>(())
/// ```
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    replace_atomically(path, |temp| write_buffered(temp, write))
}

/// Creates `path` and fills it through a buffered writer.
fn write_buffered(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let mut w = BufWriter::new(File::create(path)?);
    write(&mut w)?;
    w.flush()
}

#[cfg(test)]
mod tests;
