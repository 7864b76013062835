#!/usr/bin/env python3
"""Makes tests/fixtures/keyed_vectors/: a tiny gensim KeyedVectors saved the
way fse/word2vec-google-news-300 is (a pickle plus a separate .vectors.npy),
and gensim's own reading of it (every word, every component) for the Rust
reader to agree with.

Run with gensim installed, e.g.
    python3 -m venv /tmp/gensim-venv && /tmp/gensim-venv/bin/pip install gensim
    /tmp/gensim-venv/bin/python scripts/make_keyed_vectors_fixture.py
"""

import json
from pathlib import Path

import numpy as np
from gensim.models import KeyedVectors

OUT = Path(__file__).resolve().parent.parent / "tests" / "fixtures" / "keyed_vectors"
WORDS = [
    "pick", "put", "mug", "sink", "coffee_machine", "New_York", "café",
    "Ärger", "naïve", "", "UPPER", "lower", "42", "a.b", "x y", "ünïcödé",
    "turn", "water", "walk", "counter",
]
DIM = 6


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(20261201)
    vectors = rng.standard_normal((len(WORDS), DIM)).astype(np.float32)
    kv = KeyedVectors(vector_size=DIM)
    kv.add_vectors(WORDS, vectors)
    for rank, word in enumerate(WORDS):
        kv.set_vecattr(word, "count", len(WORDS) - rank)
    # sep_limit=0 stores the matrix apart, as it is for the 3.6 GB original.
    kv.save(str(OUT / "tiny.model"), sep_limit=0)

    again = KeyedVectors.load(str(OUT / "tiny.model"))
    expected = {
        "gensim": __import__("gensim").__version__,
        "vector_size": again.vector_size,
        "words": list(again.index_to_key),
        "vectors": [[float(x) for x in again[w]] for w in again.index_to_key],
    }
    (OUT / "tiny.expected.json").write_text(json.dumps(expected, ensure_ascii=False, indent=0) + "\n")
    for f in sorted(OUT.iterdir()):
        print(f"{f.name}: {f.stat().st_size} bytes")


if __name__ == "__main__":
    main()
