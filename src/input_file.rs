//! Opening the files a scene reads besides its sources: image textures,
//! environment images, meshes, and the EXR parts `tslc merge` and
//! `tslc info` read. Each is opened once, as a regular file, and read
//! within a documented size.
//!
//! Invariant: no such file is waited on or read without end. The file is
//! opened with `O_NONBLOCK` and its type taken from the open descriptor
//! (`fstat`), so a FIFO is refused instead of blocking `tslc check` until
//! someone writes to it, a device (a link to `/dev/zero`) is refused
//! instead of read until memory runs out, and nothing can swap the file
//! between the check and the read. Regular files ignore `O_NONBLOCK`.
//! [`BoundedText`] bounds a text file's size and line length while it is
//! read, whatever the file grows to meanwhile.

use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

/// Opens `path` for reading if it is a regular file (a symbolic link is
/// followed to its target, which must be one). Returns the file and its
/// length; the error says in words what the path is instead (no such
/// file, a directory, a FIFO, a device).
pub fn open_regular(path: &Path) -> Result<(File, u64), String> {
    let file = open_without_blocking(path).map_err(|e| reason(&e))?;
    let meta = file.metadata().map_err(|e| reason(&e))?;
    if !meta.is_file() {
        return Err(format!("it is {}, not a regular file", kind_of(&meta.file_type())));
    }
    Ok((file, meta.len()))
}

/// [`open_regular`], also refusing a file longer than `max_bytes`;
/// `what` names the kind of file in that error ("a mesh").
pub fn open_bounded(path: &Path, max_bytes: u64, what: &str) -> Result<(File, u64), String> {
    let (file, len) = open_regular(path)?;
    if len > max_bytes {
        return Err(format!("it is {}, more than the {} {what} may be", size_in_words(len), size_in_words(max_bytes)));
    }
    Ok((file, len))
}

#[cfg(unix)]
fn open_without_blocking(path: &Path) -> io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK).open(path)
}

#[cfg(not(unix))]
fn open_without_blocking(path: &Path) -> io::Result<File> {
    File::open(path)
}

/// An I/O error in the words diagnostics use ("no such file").
pub(crate) fn reason(e: &io::Error) -> String {
    match e.kind() {
        io::ErrorKind::NotFound => "no such file".into(),
        io::ErrorKind::PermissionDenied => "permission denied".into(),
        _ => e.to_string(),
    }
}

/// What a file that is not a regular file is, in words.
fn kind_of(kind: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if kind.is_char_device() {
            return "a character device";
        }
        if kind.is_block_device() {
            return "a block device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if kind.is_dir() { "a directory" } else { "not a file" }
}

/// `n` bytes in the largest binary unit that keeps it whole or near it:
/// `300 MiB`, `1 GiB`, `812 bytes`.
pub fn size_in_words(n: u64) -> String {
    const UNITS: [(u64, &str); 3] = [(1 << 30, "GiB"), (1 << 20, "MiB"), (1 << 10, "KiB")];
    for (size, unit) in UNITS {
        if n >= size {
            let x = n as f64 / size as f64;
            return if n.is_multiple_of(size) { format!("{} {unit}", n / size) } else { format!("{x:.1} {unit}") };
        }
    }
    format!("{n} bytes")
}

/// Which bound a [`BoundedText`] stopped at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextLimit {
    /// The file passed its size bound.
    Size,
    /// A line (its number, from 1) passed the line bound.
    Line(u64),
}

/// A reader of text that stops with an error once more than `max_bytes`
/// have been read or a line runs longer than `max_line` bytes, so a
/// parser that reads whole lines (tobj) never holds more than one
/// bounded line. [`BoundedText::limit`] tells afterwards which bound it
/// was, for the message: parsers keep an I/O error's kind, not its text.
#[derive(Debug)]
pub struct BoundedText<R> {
    inner: R,
    max_bytes: u64,
    max_line: u64,
    read: u64,
    /// Bytes since the last newline.
    line_run: u64,
    /// Newlines read so far.
    lines: u64,
    limit: Option<TextLimit>,
}

impl<R: Read> BoundedText<R> {
    pub fn new(inner: R, max_bytes: u64, max_line: u64) -> Self {
        BoundedText { inner, max_bytes, max_line, read: 0, line_run: 0, lines: 0, limit: None }
    }

    /// Stops bounding lines (the size bound stays): what follows is
    /// binary, such as a PLY file's payload after its text header.
    pub fn end_lines(&mut self) {
        self.max_line = u64::MAX;
    }

    /// The bound reading stopped at, if it did.
    pub fn limit(&self) -> Option<TextLimit> {
        self.limit
    }

    fn stop(&mut self, limit: TextLimit) -> io::Error {
        self.limit = Some(limit);
        io::Error::new(io::ErrorKind::InvalidData, "the file passes a bound of its size or line length")
    }
}

impl<R: Read> Read for BoundedText<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if let Some(limit) = self.limit {
            return Err(self.stop(limit));
        }
        // One byte past the bound is enough to know it was passed.
        let room = self.max_bytes.saturating_add(1).saturating_sub(self.read);
        let want = buf.len().min(usize::try_from(room).unwrap_or(usize::MAX));
        let n = self.inner.read(&mut buf[..want])?;
        self.read += n as u64;
        if self.read > self.max_bytes {
            return Err(self.stop(TextLimit::Size));
        }
        for &b in &buf[..n] {
            if b == b'\n' {
                self.lines += 1;
                self.line_run = 0;
            } else {
                self.line_run += 1;
                if self.line_run > self.max_line {
                    return Err(self.stop(TextLimit::Line(self.lines + 1)));
                }
            }
        }
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::temp_dir;

    #[test]
    fn special_files_are_refused_without_blocking() {
        let dir = temp_dir("input-special");
        assert_eq!(open_regular(&dir.join("none")).unwrap_err(), "no such file");
        assert!(open_regular(&dir).unwrap_err().contains("a directory"));
        #[cfg(unix)]
        {
            let fifo = dir.join("pipe");
            let made = std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success());
            if made {
                // Opening a FIFO for reading without O_NONBLOCK waits for a
                // writer: this would hang.
                assert!(open_regular(&fifo).unwrap_err().contains("FIFO"));
            }
            let zero = dir.join("zero");
            std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
            if Path::new("/dev/zero").exists() {
                assert!(open_regular(&zero).unwrap_err().contains("character device"));
            }
            let dangling = dir.join("dangling");
            std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
            assert_eq!(open_regular(&dangling).unwrap_err(), "no such file");
        }
        let plain = dir.join("plain.txt");
        std::fs::write(&plain, b"12345").unwrap();
        assert_eq!(open_regular(&plain).unwrap().1, 5);
        assert!(open_bounded(&plain, 4, "a test file").unwrap_err().contains("5 bytes, more than the 4 bytes"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bounded_text_stops_at_its_size_and_line_bounds() {
        let read_all = |text: &[u8], max_bytes, max_line| {
            let mut r = BoundedText::new(text, max_bytes, max_line);
            let mut out = Vec::new();
            let result = r.read_to_end(&mut out);
            (result.is_ok(), r.limit())
        };
        assert_eq!(read_all(b"ab\ncd\n", 6, 2), (true, None));
        assert_eq!(read_all(b"ab\ncd\ne", 6, 2), (false, Some(TextLimit::Size)));
        assert_eq!(read_all(b"ab\ncde\n", 100, 2), (false, Some(TextLimit::Line(2))));
        assert_eq!(read_all(b"abc", 100, 2), (false, Some(TextLimit::Line(1))));
        // A file that never ends a line stops at the line bound, not at
        // the end of the input.
        let endless = std::io::repeat(b'v');
        let mut r = BoundedText::new(endless, u64::MAX, 1000);
        let mut sink = Vec::new();
        assert!(r.read_to_end(&mut sink).is_err());
        assert_eq!(r.limit(), Some(TextLimit::Line(1)));
        assert!(sink.len() <= 1000, "{} bytes kept", sink.len());
        assert_eq!(size_in_words(1 << 30), "1 GiB");
        assert_eq!(size_in_words(3 << 19), "1.5 MiB");
        assert_eq!(size_in_words(812), "812 bytes");
    }
}
