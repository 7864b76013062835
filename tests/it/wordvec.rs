//! Word vectors: parity of the GloVe pack with the Python reference, and the
//! word2vec binary and text loaders on files written from GloVe rows.

use std::io::Write;
use std::path::{Path, PathBuf};

use mapvlm::metrics::WordVectors;
use mapvlm::models;
use mapvlm::nlp::wordvec::WordVectorTable;

fn glove() -> WordVectorTable {
    let dir = models::models_dir(None).join(models::GLOVE_6B_50D);
    WordVectorTable::load_glove_pack(&dir)
        .unwrap_or_else(|e| panic!("{e} (set MAPVLM_MODELS or run `mapvlm models fetch`)"))
}

/// `wsim(a, b)` of /work/shared/reference/pg2s_ref.py on the vectors of
/// reference/vectors.py (`load_glove_wheel_dir` of the pack), run with the
/// reference venv's NumPy (OpenBLAS, Haswell kernels) and written as the f32
/// bits of the result. The last four lie within 2e-4 of the 0.708 threshold.
const REFERENCE: &[(&str, &str, u32)] = &[
    ("pick", "grab", 0x3f286657),
    ("place", "put", 0x3f4883a4),
    ("apple", "banana", 0x3f0f901e),
    ("open", "close", 0x3f388830),
    ("cup", "mug", 0x3e49541a),
    ("Apple", "apple", 0x00000000),
    ("table", "desk", 0x3f1028fc),
    ("walk", "run", 0x3f2ee2e6),
    ("robot", "xyzzyq", 0x00000000),
    ("move", "move", 0x3f800000),
    ("take", "bring", 0x3f68c4c0),
    ("wash", "clean", 0x3f1ef12d),
    ("knife", "fork", 0x3ec11ce5),
    ("turn", "switch", 0x3f3add10),
    ("well", "gets", 0x3f3539de),
    ("will", "lot", 0x3f354044),
    ("improved", "effective", 0x3f354c52),
    (".", "2005", 0x3f3548c4),
];

#[test]
fn glove_similarities_equal_the_python_reference_bit_for_bit() {
    let table = glove();
    assert_eq!((table.len(), table.dim()), (400_000, 50));
    for &(a, b, bits) in REFERENCE {
        let got = table.similarity(a, b);
        assert_eq!(
            got.to_bits(),
            bits,
            "{a} ~ {b}: {got} vs {}",
            f32::from_bits(bits)
        );
    }
}

/// The words of [`REFERENCE`] that have vectors, in order, without repeats.
fn subset_words() -> Vec<&'static str> {
    let table = glove();
    let mut words: Vec<&str> = Vec::new();
    for &(a, b, _) in REFERENCE {
        for w in [a, b] {
            if table.vector(w).is_some() && !words.contains(&w) {
                words.push(w);
            }
        }
    }
    words
}

fn write_binary(path: &Path, rows: &[(&str, Vec<f32>)], newline: bool) {
    let mut out = std::fs::File::create(path).unwrap();
    writeln!(out, "{} {}", rows.len(), rows[0].1.len()).unwrap();
    for (word, vector) in rows {
        write!(out, "{word} ").unwrap();
        for v in vector {
            out.write_all(&v.to_le_bytes()).unwrap();
        }
        if newline {
            out.write_all(b"\n").unwrap();
        }
    }
}

fn write_text(path: &Path, rows: &[(&str, Vec<f32>)]) {
    let mut text = format!("{} {}\n", rows.len(), rows[0].1.len());
    for (word, vector) in rows {
        let values: Vec<String> = vector.iter().map(|v| v.to_string()).collect();
        text.push_str(&format!("{word} {}\n", values.join(" ")));
    }
    std::fs::write(path, text).unwrap();
}

/// GloVe rows of the subset, preceded by a decoy row for `pick` (a later row
/// of the same word must win, as in the reference's dict).
fn subset_rows(table: &WordVectorTable) -> Vec<(&'static str, Vec<f32>)> {
    let mut rows = vec![("pick", vec![1.0; 50])];
    rows.extend(
        subset_words()
            .into_iter()
            .map(|w| (w, table.vector(w).unwrap())),
    );
    rows
}

#[test]
fn word2vec_binary_and_text_files_give_the_glove_similarities() {
    let table = glove();
    let rows = subset_rows(&table);
    let dir = tempfile::tempdir().unwrap();
    let files: Vec<PathBuf> = ["with-newlines.bin", "packed.bin", "vectors.txt"]
        .iter()
        .map(|name| dir.path().join(name))
        .collect();
    write_binary(&files[0], &rows, true);
    write_binary(&files[1], &rows, false);
    write_text(&files[2], &rows);
    for file in &files {
        let loaded = WordVectorTable::load_word2vec(file).unwrap();
        assert_eq!(
            (loaded.len(), loaded.dim()),
            (rows.len() - 1, 50),
            "{file:?}"
        );
        for &(a, b, _) in REFERENCE {
            assert_eq!(
                loaded.similarity(a, b).to_bits(),
                table.similarity(a, b).to_bits(),
                "{a} ~ {b} in {file:?}"
            );
        }
    }
}

/// Loads `bytes` written to a file as word2vec and returns the error message.
fn word2vec_error(bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vectors.bin");
    std::fs::write(&path, bytes).unwrap();
    match WordVectorTable::load_word2vec(&path) {
        Ok(_) => panic!("loaded a malformed file"),
        Err(err) => err.to_string(),
    }
}

#[test]
fn malformed_word2vec_files_are_refused_with_the_place() {
    let mut binary = b"2 3\nab ".to_vec();
    binary.extend([1.0f32, 2.0, 3.0].iter().flat_map(|v| v.to_le_bytes()));
    binary.extend(b"\ncd ");
    binary.extend(1.0f32.to_le_bytes());
    let message = word2vec_error(&binary);
    assert!(
        message.contains("byte 23") && message.contains("truncated"),
        "{message}"
    );
    assert!(message.contains("`cd` (word 2 of 2)"), "{message}");

    let message = word2vec_error(b"2 3\nab");
    assert!(
        message.contains("byte 4") && message.contains("no space"),
        "{message}"
    );

    let message = word2vec_error(b"vectors of words\nab 1 2 3\n");
    assert!(
        message.contains("line 1") && message.contains("COUNT DIMENSION"),
        "{message}"
    );

    let message = word2vec_error(b"3 3\nab 1 2 3\ncd 1 2 3\nef 1 2\n");
    assert!(
        message.contains("line 4: expected 3 values after `ef`, found 2"),
        "{message}"
    );

    let message = word2vec_error(b"2 3\nab 1 2 3\ncd 1 x 3\n");
    assert!(message.contains("line 3: `x` is not a number"), "{message}");

    let message = word2vec_error(b"3 3\nab 1 2 3\ncd 1 2 3\n");
    assert!(
        message.contains("announces 3 words, the file has 2"),
        "{message}"
    );
}

#[test]
fn a_glove_pack_with_a_bad_matrix_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let real = models::models_dir(None).join(models::GLOVE_6B_50D);
    std::fs::copy(
        real.join("glove_6B_index.parquet"),
        dir.path().join("glove_6B_index.parquet"),
    )
    .unwrap();
    let npy = std::fs::read(real.join("glove_6B_50d_emb.npy")).unwrap();
    std::fs::write(dir.path().join("glove_6B_50d_emb.npy"), &npy[..1 << 20]).unwrap();
    let message = WordVectorTable::load_glove_pack(dir.path())
        .err()
        .unwrap()
        .to_string();
    assert!(
        message.contains("glove_6B_50d_emb.npy: header"),
        "{message}"
    );
    assert!(message.contains("but the file holds 1048448"), "{message}");
}
