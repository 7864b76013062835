//! The header of an `.npy` file holding a 2-D float32 matrix (NumPy format
//! versions 1 to 3), checked against the file's size, and the layout of its
//! rows for a memory map.

use std::path::Path;

use std::collections::HashMap;

use memmap2::Mmap;

use super::{RowStarts, Storage, WordVectorError, WordVectorTable};

/// What the `.npy` header says about a 2-D float32 matrix.
pub(super) struct NpyHeader {
    /// Rows of the matrix.
    pub(super) rows: usize,
    /// Columns of the matrix.
    pub(super) cols: usize,
    /// Whether the data is column-major.
    pub(super) fortran_order: bool,
    /// The byte where the data starts.
    pub(super) data_offset: usize,
}

impl NpyHeader {
    /// Parses the header of an `.npy` file (format versions 1 to 3) and checks
    /// that it describes a little-endian float32 matrix that fits the file.
    pub(super) fn parse(bytes: &[u8], path: &Path) -> Result<Self, WordVectorError> {
        let bad = |message: String| WordVectorError::format(path, "header", message);
        if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
            return Err(bad("not a .npy file (no \\x93NUMPY magic)".into()));
        }
        let (length, start) = match bytes[6] {
            1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
            2 | 3 if bytes.len() >= 12 => {
                let raw = [bytes[8], bytes[9], bytes[10], bytes[11]];
                (u32::from_le_bytes(raw) as usize, 12)
            }
            version => return Err(bad(format!("unsupported .npy format version {version}"))),
        };
        let text = bytes
            .get(start..start + length)
            .map(String::from_utf8_lossy)
            .ok_or_else(|| bad("the header runs past the end of the file".into()))?;
        if !text.contains("'descr': '<f4'") {
            return Err(bad(format!(
                "expected little-endian float32 ('<f4'), found {}",
                text.trim()
            )));
        }
        let fortran_order = text.contains("'fortran_order': True");
        let shape = regex::Regex::new(r"'shape': \((\d+), (\d+)\)")
            .ok()
            .and_then(|re| re.captures(&text))
            .and_then(|c| Some((c[1].parse::<usize>().ok()?, c[2].parse::<usize>().ok()?)));
        let Some((rows, cols)) = shape else {
            return Err(bad(format!("expected a 2-D shape, found {}", text.trim())));
        };
        let data_offset = start + length;
        let needed = rows.checked_mul(cols).and_then(|n| n.checked_mul(4));
        let available = bytes.len().saturating_sub(data_offset);
        if needed != Some(available) {
            return Err(bad(format!(
                "the header says {rows} x {cols} float32 ({} bytes of data) but the file holds {available}; the file is truncated or not this matrix, fetch it again",
                needed.map_or_else(|| "too many".to_string(), |n| n.to_string())
            )));
        }
        Ok(Self {
            rows,
            cols,
            fortran_order,
            data_offset,
        })
    }

    /// The table of this matrix, mapped as `map`, with `words` naming its
    /// rows in order (a `None` row has no word; a later duplicate wins).
    pub(super) fn table(
        &self,
        map: Mmap,
        words: impl IntoIterator<Item = Option<String>>,
    ) -> WordVectorTable {
        let (starts, stride) = self.layout();
        let mut rows = HashMap::with_capacity(self.rows);
        for (row, word) in words.into_iter().enumerate() {
            if let Some(word) = word {
                rows.insert(word.into_boxed_str(), row);
            }
        }
        WordVectorTable {
            rows,
            dim: self.cols,
            storage: Storage::Mapped {
                map,
                starts,
                stride,
            },
        }
    }

    /// Where row `i` starts and the step between its components, for the
    /// data's order.
    fn layout(&self) -> (RowStarts, usize) {
        if self.fortran_order {
            let starts = RowStarts::Linear {
                base: self.data_offset,
                step: 4,
            };
            (starts, 4 * self.rows)
        } else {
            let starts = RowStarts::Linear {
                base: self.data_offset,
                step: 4 * self.cols,
            };
            (starts, 4)
        }
    }
}
