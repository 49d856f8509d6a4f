//! A writer that hands its file only whole records ([`WholeRecords`]): the lines of a text
//! file streamed as a program runs (`wins live`'s `trajectory.tum`, its recording's `imu.csv`
//! and `baro.csv`) or the records of a binary log (the recording's CSI logs), so that a program
//! killed while it writes leaves complete lines and records only.
//!
//! Each record is formatted into a buffer; the buffer goes to the file in one `write_all` of
//! whole records, when it passes [`HAND_OFF_BYTES`] and whenever the owner calls
//! [`WholeRecords::flush`] (`wins live` does every 0.5 s, so a killed run loses at most that
//! much). A record is never split between two hand-offs, and one whose formatting fails leaves
//! nothing in the buffer.
//!
//! What the kernel does with a `write()` to a regular file when the process is killed
//! (SIGKILL): the data is in the page cache once the call returns, and a process killed before
//! or after the call leaves all of it or none. Linux checks for a fatal signal only between the
//! pages (folios) a write spans, so a kill that lands during the call itself can cut it at a
//! page boundary of the file: the window is the few microseconds the copy takes, once per
//! hand-off, and a write that stays within one page is never cut. A power loss keeps what the
//! file system had written back, which may end before the last hand-offs.

use std::io::{self, Write};

/// Bytes buffered before they are handed to the file (whole records: the record that passes
/// this goes with them, however long).
pub const HAND_OFF_BYTES: usize = 64 << 10;

/// A writer handing `W` whole records only (module doc).
///
/// ```
/// use std::io::Write;
/// use wins::io_safety::WholeRecords;
///
/// let mut w = WholeRecords::new(Vec::new());
/// w.line(|b| writeln!(b, "{} {}", 1, 2.5))?;
/// assert!(w.line(|b| write!(b, "no line end")).is_err()); // refused, nothing kept
/// assert_eq!(w.into_inner()?, b"1 2.5\n");
/// # Ok::<(), std::io::Error>(())
/// ```
#[derive(Debug)]
pub struct WholeRecords<W: Write> {
    /// The file (`None` only once [`WholeRecords::into_inner`] took it).
    inner: Option<W>,
    /// Whole records not handed yet.
    buf: Vec<u8>,
    /// Records written (buffered or handed).
    records: u64,
}

impl<W: Write> WholeRecords<W> {
    /// A writer over `inner`, which should be unbuffered (a `File`): this is the buffer.
    pub fn new(inner: W) -> Self {
        Self {
            inner: Some(inner),
            buf: Vec::with_capacity(HAND_OFF_BYTES),
            records: 0,
        }
    }

    /// Appends one record, its bytes formatted by `write` into the buffer; when `write` fails
    /// nothing of the record stays. Hands the buffer to the file when it passes
    /// [`HAND_OFF_BYTES`].
    pub fn record(&mut self, write: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) -> io::Result<()> {
        self.append(write, false)
    }

    /// Appends one or more whole lines (a record that must end with `\n`; one that does not is
    /// refused with [`io::ErrorKind::InvalidInput`] and nothing of it stays).
    pub fn line(&mut self, write: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) -> io::Result<()> {
        self.append(write, true)
    }

    fn append(
        &mut self,
        write: impl FnOnce(&mut Vec<u8>) -> io::Result<()>,
        line: bool,
    ) -> io::Result<()> {
        let start = self.buf.len();
        let written = write(&mut self.buf).and_then(|()| {
            match line && self.buf.len() > start && self.buf.last() != Some(&b'\n') {
                true => Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    "a line without its line end: a text file is written in whole lines",
                )),
                false => Ok(()),
            }
        });
        if let Err(e) = written {
            self.buf.truncate(start);
            return Err(e);
        }
        if self.buf.len() > start {
            self.records += 1;
        }
        if self.buf.len() >= HAND_OFF_BYTES {
            self.hand_off()?;
        }
        Ok(())
    }

    /// Hands the buffered records to the file in one `write_all`. On failure the buffer is
    /// dropped (how much of it reached the file is unknown) and the error returned.
    fn hand_off(&mut self) -> io::Result<()> {
        if self.buf.is_empty() {
            return Ok(());
        }
        let done = match &mut self.inner {
            Some(inner) => inner.write_all(&self.buf),
            None => Ok(()),
        };
        self.buf.clear();
        done
    }

    /// Hands every buffered record to the file and flushes it (the writer stays usable).
    pub fn flush(&mut self) -> io::Result<()> {
        self.hand_off()?;
        match &mut self.inner {
            Some(inner) => inner.flush(),
            None => Ok(()),
        }
    }

    /// Records written so far (buffered or handed to the file).
    pub fn records(&self) -> u64 {
        self.records
    }

    /// Bytes buffered, not yet handed to the file.
    pub fn buffered(&self) -> usize {
        self.buf.len()
    }

    /// Flushes ([`WholeRecords::flush`]) and gives the file back.
    pub fn into_inner(mut self) -> io::Result<W> {
        self.flush()?;
        self.inner
            .take()
            .ok_or_else(|| io::Error::other("the file was already taken"))
    }
}

impl<W: Write> Drop for WholeRecords<W> {
    /// Hands what is buffered (whole records) to the file, errors ignored: a writer dropped on
    /// an error's way out keeps its records. [`WholeRecords::flush`] reports errors.
    fn drop(&mut self) {
        let _ = self.hand_off();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file that keeps each `write` call's bytes apart.
    #[derive(Default)]
    struct Calls {
        calls: Vec<Vec<u8>>,
    }

    impl Write for Calls {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            self.calls.push(buf.to_vec());
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    fn line(k: usize) -> String {
        format!("{k} {}\n", "x".repeat(k % 97))
    }

    #[test]
    fn the_file_is_handed_whole_lines_only() {
        let mut w = WholeRecords::new(Calls::default());
        let mut want = Vec::new();
        for k in 0..5000 {
            let text = line(k);
            want.extend_from_slice(text.as_bytes());
            // Formatted in pieces, as `writeln!` does.
            w.line(|b| {
                for piece in text.as_bytes().chunks(7) {
                    b.write_all(piece)?;
                }
                Ok(())
            })
            .expect("in memory");
        }
        assert_eq!(w.records(), 5000);
        let calls = w.into_inner().expect("in memory").calls;
        assert!(calls.len() > 1, "{} hand-offs", calls.len());
        assert!(calls.iter().all(|c| c.last() == Some(&b'\n')));
        assert_eq!(calls.concat(), want);
    }

    #[test]
    fn a_failed_or_unfinished_line_leaves_nothing() {
        let mut w = WholeRecords::new(Vec::new());
        w.line(|b| writeln!(b, "first")).expect("in memory");
        let cut = w.line(|b| write!(b, "1.5 2.5 3"));
        assert_eq!(
            cut.map_err(|e| e.kind()).err(),
            Some(io::ErrorKind::InvalidInput)
        );
        let failed = w.line(|b| {
            write!(b, "half")?;
            Err(io::Error::other("formatting failed"))
        });
        assert!(failed.is_err());
        w.line(|_| Ok(())).expect("nothing is no line");
        w.record(|b| b.write_all(&[0xBB, 0, 1]))
            .expect("binary records need no line end");
        assert_eq!(w.records(), 2);
        assert_eq!(w.buffered(), 9);
        assert_eq!(w.into_inner().expect("in memory"), b"first\n\xBB\x00\x01");
    }

    #[test]
    fn flush_hands_everything_and_drop_keeps_the_records() {
        let mut w = WholeRecords::new(Calls::default());
        w.line(|b| writeln!(b, "a")).expect("in memory");
        w.line(|b| writeln!(b, "b")).expect("in memory");
        w.flush().expect("in memory");
        assert_eq!(w.buffered(), 0);
        let calls = w.inner.as_ref().map(|c| c.calls.clone());
        assert_eq!(calls, Some(vec![b"a\nb\n".to_vec()]));

        let mut file = Vec::new();
        {
            let mut w = WholeRecords::new(&mut file);
            w.line(|b| writeln!(b, "kept")).expect("in memory");
        }
        assert_eq!(file, b"kept\n");
    }

    /// A record longer than the hand-off size goes at once, whole, with those before it.
    #[test]
    fn a_long_record_goes_whole() {
        let mut w = WholeRecords::new(Calls::default());
        w.line(|b| writeln!(b, "short")).expect("in memory");
        let long = vec![b'y'; HAND_OFF_BYTES * 2];
        w.record(|b| b.write_all(&long)).expect("in memory");
        assert_eq!(w.buffered(), 0);
        w.line(|b| writeln!(b, "after")).expect("in memory");
        let calls = w.into_inner().expect("in memory").calls;
        let lens: Vec<usize> = calls.iter().map(Vec::len).collect();
        assert_eq!(lens, [6 + 2 * HAND_OFF_BYTES, 6]);
    }
}
