//! The word2vec formats: a header line `COUNT DIMENSION`, then per word
//! either the word, a space and DIMENSION little-endian f32 (binary, an
//! optional newline after each vector), or a text line `word v1 ... vD`.

use std::collections::HashMap;
use std::path::Path;

use super::{map_file, RowStarts, Storage, WordRows, WordVectorError, WordVectorTable};

pub(super) fn load(path: &Path) -> Result<WordVectorTable, WordVectorError> {
    let map = map_file(path)?;
    let (count, dim, body) = parse_header(&map, path)?;
    if first_record_is_text(&map[body..], dim) {
        load_text(path, &map[body..], count, dim)
    } else {
        let (rows, starts) = index_binary(path, &map, body, count, dim)?;
        Ok(WordVectorTable {
            rows,
            dim,
            storage: Storage::Mapped {
                map,
                starts: RowStarts::Listed(starts),
                stride: 4,
            },
        })
    }
}

/// The word count, the dimension and the offset of the first record.
fn parse_header(bytes: &[u8], path: &Path) -> Result<(usize, usize, usize), WordVectorError> {
    let end = bytes.iter().take(256).position(|&b| b == b'\n');
    let line = end.map(|end| String::from_utf8_lossy(&bytes[..end]));
    let numbers: Option<Vec<usize>> = line
        .as_deref()
        .map(|l| l.split_whitespace().map(|t| t.parse().ok()).collect())
        .and_then(|n: Option<Vec<usize>>| n.filter(|n| n.len() == 2 && n[1] > 0));
    match (numbers, end) {
        (Some(n), Some(end)) => Ok((n[0], n[1], end + 1)),
        _ => Err(WordVectorError::format(
            path,
            "line 1",
            format!(
                "expected the word2vec header `COUNT DIMENSION` (a GloVe .txt needs this line added first), found `{}`",
                line.as_deref()
                    .unwrap_or("no line")
                    .chars()
                    .take(60)
                    .collect::<String>()
            ),
        )),
    }
}

/// Whether the first record is a text line with a word and `dim` numbers.
fn first_record_is_text(body: &[u8], dim: usize) -> bool {
    let end = body.iter().position(|&b| b == b'\n').unwrap_or(body.len());
    let Ok(line) = std::str::from_utf8(&body[..end]) else {
        return false;
    };
    let tokens: Vec<&str> = line.split_whitespace().collect();
    tokens.len() == dim + 1 && tokens[1..].iter().all(|t| t.parse::<f32>().is_ok())
}

/// Indexes a binary body: word → row and the byte offset of each row's
/// vector, checking that every vector lies inside the file.
fn index_binary(
    path: &Path,
    bytes: &[u8],
    body: usize,
    count: usize,
    dim: usize,
) -> Result<(WordRows, Vec<usize>), WordVectorError> {
    let width = dim * 4;
    let mut rows = HashMap::with_capacity(count);
    let mut starts = Vec::with_capacity(count);
    let mut pos = body;
    for row in 0..count {
        while bytes.get(pos).is_some_and(|&b| b == b'\n') {
            pos += 1;
        }
        let Some(length) = bytes[pos..].iter().position(|&b| b == b' ') else {
            return Err(WordVectorError::format(
                path,
                format!("byte {pos}"),
                format!(
                    "word {} of {count} has no space after it: the file is truncated or not word2vec",
                    row + 1
                ),
            ));
        };
        let word = String::from_utf8_lossy(&bytes[pos..pos + length]);
        pos += length + 1;
        if bytes.len() - pos < width {
            return Err(WordVectorError::format(
                path,
                format!("byte {pos}"),
                format!(
                    "the vector of `{word}` (word {} of {count}) needs {width} bytes, {} are left: the file is truncated",
                    row + 1,
                    bytes.len() - pos
                ),
            ));
        }
        rows.insert(word.into(), row);
        starts.push(pos);
        pos += width;
    }
    Ok((rows, starts))
}

/// Reads a text body into memory.
fn load_text(
    path: &Path,
    body: &[u8],
    count: usize,
    dim: usize,
) -> Result<WordVectorTable, WordVectorError> {
    let text = std::str::from_utf8(body).map_err(|e| {
        let line = 2 + body[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        WordVectorError::format(path, format!("line {line}"), "not valid UTF-8")
    })?;
    let mut rows = HashMap::with_capacity(count);
    let mut values = Vec::with_capacity(count * dim);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    for row in 0..count {
        let Some((index, line)) = lines.next() else {
            return Err(WordVectorError::format(
                path,
                "end of file",
                format!("the header announces {count} words, the file has {row}"),
            ));
        };
        let at = format!("line {}", index + 2);
        let mut tokens = line.split_whitespace();
        let word = tokens.next().unwrap_or_default();
        let before = values.len();
        for token in tokens {
            let value = token.parse::<f32>().map_err(|_| {
                WordVectorError::format(path, &at, format!("`{token}` is not a number"))
            })?;
            values.push(value);
        }
        let found = values.len() - before;
        if found != dim {
            return Err(WordVectorError::format(
                path,
                at,
                format!("expected {dim} values after `{word}`, found {found}"),
            ));
        }
        rows.insert(word.into(), row);
    }
    Ok(WordVectorTable {
        rows,
        dim,
        storage: Storage::Owned(values),
    })
}
