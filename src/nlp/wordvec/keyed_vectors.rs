//! gensim KeyedVectors as `KeyedVectors.save(PATH)` leaves them: a pickle at
//! `PATH` whose object holds the vocabulary (`index_to_key` in gensim 4,
//! `index2word` in gensim 3) and the matrix beside it at
//! `PATH.vectors.npy`, which is memory-mapped. The pickle is read as data
//! only (serde-pickle; classes and globals are never resolved or run).

use std::ffi::OsString;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::npy::NpyHeader;
use super::{map_file, WordVectorError, WordVectorTable};

/// The attributes of a pickled KeyedVectors object this reader needs; the
/// others are skipped.
#[derive(Debug, Deserialize)]
struct PickledKeyedVectors {
    /// The words in row order (gensim 4).
    #[serde(default)]
    index_to_key: Option<Vec<String>>,
    /// The words in row order (gensim 3).
    #[serde(default)]
    index2word: Option<Vec<String>>,
    /// The number of components (gensim 4).
    #[serde(default)]
    vector_size: Option<usize>,
}

/// The matrix file gensim writes beside the pickle at `path`.
pub(super) fn matrix_path(path: &Path) -> PathBuf {
    let mut name = OsString::from(path.as_os_str());
    name.push(".vectors.npy");
    PathBuf::from(name)
}

pub(super) fn load(path: &Path) -> Result<WordVectorTable, WordVectorError> {
    let (words, vector_size) = read_vocabulary(path)?;
    let matrix = matrix_path(path);
    let map = map_file(&matrix)?;
    let header = NpyHeader::parse(&map, &matrix)?;
    if header.rows != words.len() {
        return Err(WordVectorError::format(
            &matrix,
            "header",
            format!(
                "{} rows, but the vocabulary in {} has {} words; the two files are not one KeyedVectors",
                header.rows,
                path.display(),
                words.len()
            ),
        ));
    }
    if let Some(size) = vector_size.filter(|&size| size != header.cols) {
        return Err(WordVectorError::format(
            &matrix,
            "header",
            format!(
                "{} columns, but the vocabulary says vector_size {size}",
                header.cols
            ),
        ));
    }
    Ok(header.table(map, words.into_iter().map(Some)))
}

/// The words of the pickled vocabulary in row order, and the vector size it
/// states, if any.
fn read_vocabulary(path: &Path) -> Result<(Vec<String>, Option<usize>), WordVectorError> {
    let not_keyed_vectors = |detail: String| {
        WordVectorError::format(
            path,
            "pickle",
            format!("not a gensim KeyedVectors vocabulary ({detail}); give the file KeyedVectors.save wrote, with its .vectors.npy beside it"),
        )
    };
    let file = std::fs::File::open(path).map_err(WordVectorError::io(path))?;
    let options = serde_pickle::DeOptions::new().replace_unresolved_globals();
    let pickled: PickledKeyedVectors = serde_pickle::from_reader(BufReader::new(file), options)
        .map_err(|e| not_keyed_vectors(e.to_string()))?;
    let words = pickled
        .index_to_key
        .or(pickled.index2word)
        .ok_or_else(|| not_keyed_vectors("it has neither index_to_key nor index2word".into()))?;
    Ok((words, pickled.vector_size))
}
