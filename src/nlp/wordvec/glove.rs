//! The default GloVe pack: a float32 `.npy` matrix (C or Fortran order) and a
//! parquet file whose one string column lists the words in row order.

use std::collections::HashMap;
use std::path::Path;

use parquet::column::reader::ColumnReader;
use parquet::file::reader::{FileReader, SerializedFileReader};

use super::{map_file, RowStarts, Storage, WordVectorError, WordVectorTable};

/// File name of the matrix inside the pack folder.
const MATRIX: &str = "glove_6B_50d_emb.npy";
/// File name of the word index inside the pack folder.
const INDEX: &str = "glove_6B_index.parquet";

pub(super) fn load(dir: &Path) -> Result<WordVectorTable, WordVectorError> {
    let words = read_words(&dir.join(INDEX))?;
    let matrix_path = dir.join(MATRIX);
    let map = map_file(&matrix_path)?;
    let header = NpyHeader::parse(&map, &matrix_path)?;
    if header.rows != words.len() {
        return Err(WordVectorError::format(
            &matrix_path,
            "header",
            format!(
                "{} rows, but the word index {} lists {} words",
                header.rows,
                INDEX,
                words.len()
            ),
        ));
    }
    let (starts, stride) = if header.fortran_order {
        let starts = RowStarts::Linear {
            base: header.data_offset,
            step: 4,
        };
        (starts, 4 * header.rows)
    } else {
        let starts = RowStarts::Linear {
            base: header.data_offset,
            step: 4 * header.cols,
        };
        (starts, 4)
    };
    let mut rows = HashMap::with_capacity(words.len());
    for (row, word) in words.into_iter().enumerate() {
        if let Some(word) = word {
            rows.insert(word.into_boxed_str(), row);
        }
    }
    Ok(WordVectorTable {
        rows,
        dim: header.cols,
        storage: Storage::Mapped {
            map,
            starts,
            stride,
        },
    })
}

/// The words of the index in row order; `None` for a null entry.
fn read_words(path: &Path) -> Result<Vec<Option<String>>, WordVectorError> {
    let parquet_err = |source| WordVectorError::Parquet {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(WordVectorError::io(path))?;
    let reader = SerializedFileReader::new(file).map_err(parquet_err)?;
    let mut words = Vec::new();
    for group in 0..reader.num_row_groups() {
        let row_group = reader.get_row_group(group).map_err(parquet_err)?;
        let column = row_group.get_column_reader(0).map_err(parquet_err)?;
        let ColumnReader::ByteArrayColumnReader(mut column) = column else {
            return Err(WordVectorError::format(
                path,
                "column 0",
                "expected a string column of words",
            ));
        };
        let max_level = row_group
            .metadata()
            .column(0)
            .column_descr()
            .max_def_level();
        let (mut levels, mut values) = (Vec::new(), Vec::new());
        loop {
            levels.clear();
            values.clear();
            let (records, _, _) = column
                .read_records(8192, Some(&mut levels), None, &mut values)
                .map_err(parquet_err)?;
            if records == 0 {
                break;
            }
            let text =
                |v: &parquet::data_type::ByteArray| String::from_utf8_lossy(v.data()).into_owned();
            if max_level == 0 {
                words.extend(values.iter().map(|v| Some(text(v))));
            } else {
                let mut values = values.iter();
                for level in &levels {
                    let present = *level == max_level;
                    words.push(if present {
                        values.next().map(text)
                    } else {
                        None
                    });
                }
            }
        }
    }
    Ok(words)
}

/// What the `.npy` header says about a 2-D float32 matrix.
struct NpyHeader {
    rows: usize,
    cols: usize,
    fortran_order: bool,
    data_offset: usize,
}

impl NpyHeader {
    /// Parses the header of an `.npy` file (format versions 1 to 3) and checks
    /// that it describes a little-endian float32 matrix that fits the file.
    fn parse(bytes: &[u8], path: &Path) -> Result<Self, WordVectorError> {
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
        if needed.is_none_or(|needed| needed > available) {
            return Err(bad(format!(
                "{rows} x {cols} float32 do not fit the {available} bytes of data in the file"
            )));
        }
        Ok(Self {
            rows,
            cols,
            fortran_order,
            data_offset,
        })
    }
}
