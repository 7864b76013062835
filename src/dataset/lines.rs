//! Reading text files line by line with bounded memory: a line longer than
//! a limit is skipped or cut (never kept whole in memory), a line that is
//! not UTF-8 is reported with its number while the others are read, and a
//! UTF-8 byte-order mark at the start is dropped.

use std::io::{self, BufRead};

/// The UTF-8 byte-order mark some editors put at the start of a file.
pub const BOM: &str = "\u{feff}";

/// Why one line could not be used as text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LineProblem {
    /// The line is not UTF-8; the offset is that of its first invalid byte.
    NotUtf8 {
        /// Offset of the first invalid byte within the line.
        offset: usize,
    },
    /// The line is longer than the limit; it was skipped unread.
    TooLong {
        /// The line's length in bytes.
        bytes: usize,
        /// The limit it passed.
        limit: usize,
    },
}

impl std::fmt::Display for LineProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NotUtf8 { offset } => {
                write!(
                    f,
                    "not UTF-8 text (byte {offset} of the line); save the file as UTF-8"
                )
            }
            Self::TooLong { bytes, limit } => write!(
                f,
                "line of {bytes} bytes is longer than the limit of {limit}; split it"
            ),
        }
    }
}

/// One line read: its 1-based number and its text, or why it has none.
pub type NumberedLine = (usize, Result<String, LineProblem>);

/// The lines of a reader, each at most `limit` bytes kept in memory.
pub struct BoundedLines<R> {
    source: R,
    limit: usize,
    cut: bool,
    line: usize,
    buf: Vec<u8>,
}

impl<R: BufRead> BoundedLines<R> {
    /// Lines of `source`, skipping (and reporting) any longer than `limit` bytes.
    pub fn new(source: R, limit: usize) -> Self {
        Self {
            source,
            limit,
            cut: false,
            line: 0,
            buf: Vec::new(),
        }
    }

    /// Lines of `source`, a line longer than `limit` bytes cut to its first
    /// `limit` bytes (less a character the cut would split) instead of
    /// skipped, for readers where the start of a line is still worth having.
    pub fn cutting(source: R, limit: usize) -> Self {
        Self {
            cut: true,
            ..Self::new(source, limit)
        }
    }

    /// Reads the next line's bytes into `self.buf` (at most `limit` of them);
    /// returns the line's whole length, or `None` at the end.
    fn read_line(&mut self) -> io::Result<Option<usize>> {
        self.buf.clear();
        let mut total = 0;
        loop {
            let available = match self.source.fill_buf() {
                Ok(bytes) => bytes,
                Err(err) if err.kind() == io::ErrorKind::Interrupted => continue,
                Err(err) => return Err(err),
            };
            if available.is_empty() {
                return Ok((total > 0).then_some(total));
            }
            let (part, done) = match available.iter().position(|&b| b == b'\n') {
                Some(end) => (&available[..end], Some(end + 1)),
                None => (available, None),
            };
            let room = (self.limit + 1).saturating_sub(self.buf.len());
            self.buf.extend_from_slice(&part[..part.len().min(room)]);
            total += part.len();
            let used = done.unwrap_or(available.len());
            self.source.consume(used);
            if done.is_some() {
                return Ok(Some(total + 1));
            }
        }
    }
}

impl<R: BufRead> Iterator for BoundedLines<R> {
    type Item = io::Result<NumberedLine>;

    fn next(&mut self) -> Option<Self::Item> {
        let length = match self.read_line() {
            Ok(Some(length)) => length,
            Ok(None) => return None,
            Err(err) => return Some(Err(err)),
        };
        self.line += 1;
        if self.buf.last() == Some(&b'\r') && self.buf.len() <= self.limit {
            self.buf.pop();
        }
        if self.line == 1 && self.buf.starts_with(BOM.as_bytes()) {
            self.buf.drain(..BOM.len());
        }
        let cut = self.buf.len() > self.limit;
        if cut && self.cut {
            self.buf.truncate(self.limit);
        } else if cut {
            return Some(Ok((
                self.line,
                Err(LineProblem::TooLong {
                    bytes: length,
                    limit: self.limit,
                }),
            )));
        }
        let text = match std::str::from_utf8(&self.buf) {
            Ok(text) => Ok(text.to_string()),
            // The cut split a character: keep what comes before it.
            Err(err) if cut && err.error_len().is_none() => {
                Ok(String::from_utf8_lossy(&self.buf[..err.valid_up_to()]).into_owned())
            }
            Err(err) => Err(LineProblem::NotUtf8 {
                offset: err.valid_up_to(),
            }),
        };
        Some(Ok((self.line, text)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(bytes: &[u8], limit: usize) -> Vec<NumberedLine> {
        BoundedLines::new(bytes, limit)
            .map(|l| l.unwrap_or_else(|e| panic!("{e}")))
            .collect()
    }

    #[test]
    fn a_bom_is_dropped_crlf_removed_and_a_bad_line_reported_alone() {
        let got = lines(b"\xef\xbb\xbfone\r\ntw\xffo\nthree", 100);
        assert_eq!(got[0], (1, Ok("one".to_string())));
        assert_eq!(got[1], (2, Err(LineProblem::NotUtf8 { offset: 2 })));
        assert_eq!(got[2], (3, Ok("three".to_string())));
        assert_eq!(got.len(), 3);
    }

    #[test]
    fn a_long_line_is_skipped_without_being_kept() {
        let mut text = vec![b'x'; 50];
        text.extend_from_slice(b"\nshort\n");
        let got = lines(&text, 10);
        assert_eq!(
            got[0],
            (
                1,
                Err(LineProblem::TooLong {
                    bytes: 51,
                    limit: 10
                })
            )
        );
        assert_eq!(got[1], (2, Ok("short".to_string())));
        let reader = io::BufReader::with_capacity(4, &text[..]);
        let got: Vec<_> = BoundedLines::new(reader, 10).flatten().collect();
        assert_eq!(got[1], (2, Ok("short".to_string())));
    }

    #[test]
    fn a_cutting_reader_keeps_the_start_of_a_long_line_on_a_character_boundary() {
        let mut text = "é".repeat(30).into_bytes();
        text.extend_from_slice(b"\nshort\n");
        let reader = io::BufReader::with_capacity(4, &text[..]);
        let got: Vec<_> = BoundedLines::cutting(reader, 11).flatten().collect();
        assert_eq!(got[0], (1, Ok("é".repeat(5))));
        assert_eq!(got[1], (2, Ok("short".to_string())));
    }

    mod properties {
        use super::super::*;
        use proptest::prelude::*;

        fn read(bytes: &[u8], limit: usize, capacity: usize, cutting: bool) -> Vec<NumberedLine> {
            let reader = io::BufReader::with_capacity(capacity, bytes);
            let lines = if cutting {
                BoundedLines::cutting(reader, limit)
            } else {
                BoundedLines::new(reader, limit)
            };
            lines.map(|l| l.unwrap_or_else(|e| panic!("{e}"))).collect()
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(256))]

            /// Any bytes: numbered lines, none kept over the limit, and the
            /// same lines however the reader's buffer cuts the input.
            #[test]
            fn lines_are_bounded_and_independent_of_the_buffer(
                bytes in prop::collection::vec(prop::sample::select(b"ab\xc3\xa9\xff\r\n".to_vec()), 0..200),
                limit in 1usize..40,
                capacity in 1usize..16,
                cutting in any::<bool>(),
            ) {
                let lines = read(&bytes, limit, capacity, cutting);
                prop_assert_eq!(&lines, &read(&bytes, limit, 1 << 16, cutting));
                for (i, (n, text)) in lines.iter().enumerate() {
                    prop_assert_eq!(*n, i + 1);
                    match text {
                        Ok(text) => prop_assert!(text.len() <= limit),
                        Err(LineProblem::TooLong { bytes, .. }) => {
                            prop_assert!(!cutting);
                            prop_assert!(*bytes > limit);
                        }
                        Err(LineProblem::NotUtf8 { .. }) => {}
                    }
                }
            }

            /// Lines within the limit come back exactly as written.
            #[test]
            fn short_lines_read_back_as_written(
                written in prop::collection::vec("[a-zé水 ]{0,10}", 0..20),
                crlf in any::<bool>(),
            ) {
                let end = if crlf { "\r\n" } else { "\n" };
                let text: String = written.iter().map(|l| format!("{l}{end}")).collect();
                let lines = read(text.as_bytes(), 40, 5, false);
                let back: Vec<String> = lines.into_iter().map(|(_, t)| t.unwrap_or_default()).collect();
                prop_assert_eq!(back, written);
            }
        }
    }
}
