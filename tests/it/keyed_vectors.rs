//! The gensim KeyedVectors reader against gensim itself, on the fixture
//! `scripts/make_keyed_vectors_fixture.py` made (a pickle and a separate
//! `.vectors.npy`, as fse/word2vec-google-news-300 is kept), and its
//! refusals of damaged or foreign files.

use std::fs;
use std::path::{Path, PathBuf};

use mapvlm::nlp::wordvec::WordVectorTable;

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/keyed_vectors")
}

#[test]
fn the_reader_agrees_with_gensim_on_every_word_and_component() {
    let expected: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(fixture().join("tiny.expected.json")).unwrap())
            .unwrap();
    let table = WordVectorTable::load_keyed_vectors(&fixture().join("tiny.model")).unwrap();
    let words = expected["words"].as_array().unwrap();
    let vectors = expected["vectors"].as_array().unwrap();
    assert_eq!(table.len(), words.len());
    assert_eq!(
        table.dim() as u64,
        expected["vector_size"].as_u64().unwrap()
    );
    for (word, vector) in words.iter().zip(vectors) {
        let word = word.as_str().unwrap();
        let got = table
            .vector(word)
            .unwrap_or_else(|| panic!("{word:?} missing"));
        let want: Vec<f32> = vector
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        assert_eq!(got, want, "{word:?}");
    }
    assert!(table.vector("Pick").is_none(), "lookup is case-sensitive");
}

/// A copy of the fixture in a temporary folder, for damaging.
fn copy_of_fixture(dir: &Path) -> PathBuf {
    for name in ["tiny.model", "tiny.model.vectors.npy"] {
        fs::copy(fixture().join(name), dir.join(name)).unwrap();
    }
    dir.join("tiny.model")
}

fn error_of(path: &Path) -> String {
    match WordVectorTable::load_keyed_vectors(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(err) => err.to_string(),
    }
}

#[test]
fn a_matrix_whose_header_does_not_match_its_size_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = copy_of_fixture(dir.path());
    let npy = dir.path().join("tiny.model.vectors.npy");
    let bytes = fs::read(&npy).unwrap();
    fs::write(&npy, &bytes[..bytes.len() - 4]).unwrap();
    let line = error_of(&model);
    assert!(
        line.contains("tiny.model.vectors.npy: header: the header says 20 x 6 float32 (480 bytes of data) but the file holds 476"),
        "{line}"
    );
    fs::write(&npy, [&bytes[..], &[0u8; 4]].concat()).unwrap();
    assert!(error_of(&model).contains("the file holds 484"));
}

#[test]
fn a_pickle_that_is_not_a_keyed_vectors_vocabulary_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let model = copy_of_fixture(dir.path());
    // A pickled list of words: a pickle, but not a KeyedVectors object.
    let list = serde_pickle::to_vec(&vec!["pick", "put"], serde_pickle::SerOptions::new()).unwrap();
    fs::write(&model, list).unwrap();
    let line = error_of(&model);
    assert!(
        line.contains("tiny.model: pickle: not a gensim KeyedVectors vocabulary"),
        "{line}"
    );
    // A dict without a vocabulary.
    let dict: std::collections::BTreeMap<&str, u32> = [("vector_size", 6)].into();
    fs::write(
        &model,
        serde_pickle::to_vec(&dict, serde_pickle::SerOptions::new()).unwrap(),
    )
    .unwrap();
    assert!(error_of(&model).contains("neither index_to_key nor index2word"));
    // Not a pickle at all.
    fs::write(&model, b"word2vec text, not a pickle\n").unwrap();
    assert!(error_of(&model).contains("not a gensim KeyedVectors vocabulary"));
    // One line each.
    assert!(!error_of(&model).contains('\n'));
}

#[test]
fn a_missing_matrix_names_the_file_expected() {
    let dir = tempfile::tempdir().unwrap();
    let model = copy_of_fixture(dir.path());
    fs::remove_file(dir.path().join("tiny.model.vectors.npy")).unwrap();
    let line = error_of(&model);
    assert!(line.contains("tiny.model.vectors.npy"), "{line}");
}
