#!/usr/bin/env python3
"""Times the Python reference (../shared/reference) on the same work as the
criterion benches, so the two can be reported side by side as ratios.

usage: bench_reference.py MODELS_DIR {embed64,pair,pairs40,words} [REPEATS]

  embed64  sentences/s embedding the 64 lines of golden/sentences.embed.txt
           (batch size 32, as sentence-transformers' default)
  pair     one 6x10 plan pair, cold (empty caches) and warm (one step edited)
  pairs40  40 ALFRED pairs of golden/pairs.dev.jsonl, model loading excluded
  words    spaCy's words (tokens)/s on golden/sentences.dev.txt, with nlp.pipe
           and one sentence at a time
Prints one JSON object.
"""
import json
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.join(HERE, "..", "..", "shared")
sys.path.insert(0, os.path.join(SHARED, "reference"))

import pg2s_ref  # noqa: E402
from vectors import load_glove_wheel_dir  # noqa: E402


def load(models):
    return pg2s_ref.Models(f"{models}/all-mpnet-base-v2", f"{models}/en_core_web_sm-3.8.0",
                           load_glove_wheel_dir(f"{models}/glove-6b-50d"))


def timed(fn, repeats, setup=lambda: None):
    times = []
    for _ in range(repeats):
        setup()
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def six_by_ten():
    """The first golden pair with a 6-step ground truth and the longest prediction, padded to 10."""
    pairs = [json.loads(l) for l in open(os.path.join(SHARED, "golden", "pairs.dev.jsonl"))]
    gt = next(p["gt"] for p in pairs if len(p["gt"]) == 6)
    pool = [s for p in pairs for s in p["pred"]]
    return gt, pool[:10]


def main():
    models, what = sys.argv[1], sys.argv[2]
    repeats = int(sys.argv[3]) if len(sys.argv) > 3 else 5
    m = load(models)
    if what == "embed64":
        sents = [l.rstrip("\n") for l in open(os.path.join(SHARED, "golden", "sentences.embed.txt")) if l.strip()]
        t = timed(lambda: m.st.encode(sents, batch_size=32), repeats)
        print(json.dumps({"what": what, "seconds": t, "sentences_per_s": len(sents) / t}))
    elif what == "pair":
        gt, pred = six_by_ten()
        edited = pred[:3] + [pred[3] + " Then wait."] + pred[4:]

        def cold():
            m._cache.clear()
            pg2s_ref.pg2s(m, gt, pred)

        def prepare():
            pg2s_ref.pg2s(m, gt, pred)
            m._cache.pop(edited[3], None)

        warm = timed(lambda: pg2s_ref.pg2s(m, gt, edited), repeats, prepare)
        print(json.dumps({"what": what, "cold_s": timed(cold, repeats), "warm_s": warm}))
    elif what == "pairs40":
        pairs = [json.loads(l) for l in open(os.path.join(SHARED, "golden", "pairs.dev.jsonl"))][:40]

        def run():
            m._cache.clear()
            m.embed([s for p in pairs for s in p["gt"] + p["pred"]])
            for p in pairs:
                pg2s_ref.pg2s(m, p["gt"], p["pred"])

        print(json.dumps({"what": what, "seconds": timed(run, repeats)}))
    elif what == "words":
        sents = [l.rstrip("\n") for l in open(os.path.join(SHARED, "golden", "sentences.dev.txt"))]
        words = sum(len(d) for d in m.nlp.pipe(sents))
        piped = timed(lambda: list(m.nlp.pipe(sents)), repeats)
        single = timed(lambda: [m.nlp(s) for s in sents], repeats)
        print(json.dumps({"what": what, "words": words, "pipe_words_per_s": words / piped,
                          "one_at_a_time_words_per_s": words / single}))


if __name__ == "__main__":
    main()
