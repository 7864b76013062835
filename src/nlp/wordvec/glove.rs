//! The default GloVe pack: a float32 `.npy` matrix (C or Fortran order) and a
//! parquet file whose one string column lists the words in row order.

use std::path::Path;

use parquet::column::reader::ColumnReader;
use parquet::file::reader::{FileReader, SerializedFileReader};

use super::npy::NpyHeader;
use super::{map_file, WordVectorError, WordVectorTable};

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
    Ok(header.table(map, words))
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
