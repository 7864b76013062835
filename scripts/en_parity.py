#!/usr/bin/env python3
"""Compares `mapvlm parse --json` with spaCy en_core_web_sm 3.8.0 on any
text: token texts and whitespace per sentence, then tag, pos, dep and head
per token; lists every sentence that differs.

usage: en_parity.py PYTHON MODEL_DIR TEXT_FILE [MAPVLM]

PYTHON has spaCy (../shared/reference/setup.sh makes one), MODEL_DIR is the
pack's en_core_web_sm-3.8.0 folder, TEXT_FILE holds one sentence or
paragraph a line, MAPVLM defaults to target/release/mapvlm.
"""
import json
import subprocess
import sys

SPACY = """
import json, sys, spacy
nlp = spacy.load(sys.argv[1])
for line in open(sys.argv[2], encoding="utf-8"):
    doc = nlp(line.rstrip("\\n"))
    print(json.dumps([{"text": t.text, "ws": t.whitespace_, "tag": t.tag_, "pos": t.pos_,
                       "dep": t.dep_, "head": t.head.i} for t in doc]))
"""
FIELDS = ("tag", "pos", "dep", "head")


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    python, model, text_file = sys.argv[1:4]
    mapvlm = sys.argv[4] if len(sys.argv) == 5 else "target/release/mapvlm"
    theirs = subprocess.run([python, "-c", SPACY, model, text_file], check=True,
                            capture_output=True, text=True).stdout.splitlines()
    with open(text_file, encoding="utf-8") as f:
        ours = subprocess.run([mapvlm, "parse", "--json"], stdin=f, check=True,
                              capture_output=True, text=True).stdout.splitlines()
    tokens, agree, boundary, differing = 0, dict.fromkeys(FIELDS, 0), [], []
    for mine_line, theirs_line in zip(ours, theirs):
        entry = json.loads(mine_line)
        mine, ref = entry["tokens"], json.loads(theirs_line)
        if [(t["text"], t["ws"]) for t in mine] != [(t["text"], t["ws"]) for t in ref]:
            boundary.append(entry["text"])
            continue
        fields_off = set()
        for a, b in zip(mine, ref):
            tokens += 1
            for field in FIELDS:
                same = a[field] == b[field]
                agree[field] += same
                if not same:
                    fields_off.add(f"{field} of {a['text']!r}: {a[field]} vs spaCy {b[field]}")
        if fields_off:
            differing.append((entry["text"], sorted(fields_off)))
    print(f"sentences {len(theirs)}, token boundaries differ in {len(boundary)}, tokens compared {tokens}")
    for field in FIELDS:
        print(f"{field:>5}: {agree[field]}/{tokens} = {100 * agree[field] / max(tokens, 1):.3f}%")
    for text in boundary:
        print(f"boundaries differ: {text}")
    for text, why in differing:
        print(f"differs: {text}\n    " + "\n    ".join(why))


if __name__ == "__main__":
    main()
