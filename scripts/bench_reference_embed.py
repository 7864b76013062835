"""Times the Python reference encoder on the benchmark sentences.

Usage: bench_reference_embed.py MODEL_DIR SENTENCES_FILE [ROUNDS]

Loads MODEL_DIR with sentence-transformers and times
``encode(sentences, batch_size=32)`` on the non-blank lines of
SENTENCES_FILE, the same work `cargo bench --bench embed` measures. Prints
one JSON line: sentences, rounds, best and median seconds, sentences/s and
torch's thread count.
"""

import json
import statistics
import sys
import time


def main() -> int:
    if len(sys.argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    model_dir, sentences_file = sys.argv[1], sys.argv[2]
    rounds = int(sys.argv[3]) if len(sys.argv) == 4 else 10

    import torch
    from sentence_transformers import SentenceTransformer

    with open(sentences_file, encoding="utf-8") as handle:
        sentences = [line.rstrip("\n") for line in handle if line.strip()]
    model = SentenceTransformer(model_dir, device="cpu")
    model.encode(sentences, batch_size=32)  # warm-up
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        model.encode(sentences, batch_size=32)
        times.append(time.perf_counter() - start)
    median = statistics.median(times)
    print(
        json.dumps(
            {
                "sentences": len(sentences),
                "rounds": rounds,
                "best_s": min(times),
                "median_s": median,
                "sentences_per_s": len(sentences) / median,
                "torch_threads": torch.get_num_threads(),
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
