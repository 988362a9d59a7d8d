//! Input of bounded line length: a file read through [`BoundedLines`] fails with one short
//! error as soon as a line passes [`MAX_LINE_BYTES`], so that a file that is not a record (a
//! disk image, `/dev/zero`, a gigabyte without a newline) costs a few kilobytes of memory and
//! an instant, not the whole file in memory and an error message as long as it.

use std::io::{self, Read};

/// Longest line a record or scope CSV may have [bytes] (a record line is a few dozen bytes;
/// a scope export with many channels a few hundred).
pub const MAX_LINE_BYTES: usize = 16 * 1024;

/// Most characters of the input an error message quotes.
pub const QUOTED_CHARS: usize = 80;

/// `inner`, refusing a line longer than [`MAX_LINE_BYTES`] with an
/// [`io::ErrorKind::InvalidData`] error that names the line.
pub struct BoundedLines<R> {
    inner: R,
    /// Bytes since the last newline.
    run: usize,
    /// Lines ended so far.
    lines: u64,
}

impl<R: Read> BoundedLines<R> {
    /// Wrap `inner`.
    pub fn new(inner: R) -> Self {
        BoundedLines {
            inner,
            run: 0,
            lines: 0,
        }
    }
}

impl<R: Read> Read for BoundedLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                (self.run, self.lines) = (0, self.lines + 1);
            } else {
                self.run += 1;
                if self.run > MAX_LINE_BYTES {
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidData,
                        format!(
                            "line {} is longer than {MAX_LINE_BYTES} bytes: not a record CSV",
                            self.lines + 1
                        ),
                    ));
                }
            }
        }
        Ok(n)
    }
}

/// `text` for an error message: at most [`QUOTED_CHARS`] characters, escaped, with `...`
/// when cut.
pub fn quoted(text: &str) -> String {
    let mut chars = text.chars();
    let head: String = chars.by_ref().take(QUOTED_CHARS).collect();
    let more = if chars.next().is_some() { "..." } else { "" };
    format!("{}{more}", head.escape_default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_past_the_bound_is_refused_with_its_number() {
        let mut text = b"t,v,omega\n0,1,2\n".to_vec();
        text.extend(std::iter::repeat_n(b'x', MAX_LINE_BYTES + 1));
        let mut out = Vec::new();
        let err = BoundedLines::new(text.as_slice())
            .read_to_end(&mut out)
            .unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidData);
        assert!(err.to_string().starts_with("line 3 is longer"), "{err}");
        let ok = b"t,v,omega\n0,1,2\n";
        let mut out = Vec::new();
        BoundedLines::new(ok.as_slice())
            .read_to_end(&mut out)
            .unwrap();
        assert_eq!(out, ok);
    }

    #[test]
    fn quotes_are_cut_at_eighty_characters() {
        assert_eq!(quoted("a\tb"), "a\\tb");
        let long = "\0".repeat(1000);
        let q = quoted(&long);
        assert!(
            q.ends_with("...") && q.len() <= 6 * QUOTED_CHARS + 3,
            "{}",
            q.len()
        );
    }
}
