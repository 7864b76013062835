#!/usr/bin/env python3
"""Prints the comparison scripts/bench measured: criterion's medians beside
the reference's timings, as ratios, and the encoder's FLOP/s as a share of
what this machine's cores can do in f32.

usage: bench_report.py REPORT_DIR   (written by scripts/bench)
"""
import glob
import json
import os
import re
import sys


def criterion_medians(root):
    """Median seconds of every criterion benchmark, by its full id."""
    medians = {}
    for path in glob.glob(os.path.join(root, "**", "new", "benchmark.json"), recursive=True):
        with open(path) as f:
            full_id = json.load(f)["full_id"]
        with open(os.path.join(os.path.dirname(path), "estimates.json")) as f:
            medians[full_id] = json.load(f)["median"]["point_estimate"] / 1e9
    return medians


def peak_f32_flops():
    """Cores x clock x 32 (two 8-wide FMA units, 2 FLOP each) for AVX2+FMA cores."""
    cores = os.cpu_count() or 1
    with open("/proc/cpuinfo") as f:
        mhz = max(float(m) for m in re.findall(r"cpu MHz\s*:\s*([\d.]+)", f.read()))
    return cores, mhz, cores * mhz * 1e6 * 32


def main():
    out = sys.argv[1]
    ref = {}
    for what in ("embed64", "pair", "pairs40", "words"):
        with open(os.path.join(out, f"reference-{what}.json")) as f:
            ref[what] = json.load(f)
    with open(os.path.join(out, "whole-process.json")) as f:
        whole = json.load(f)
    ours = criterion_medians(os.path.join("target", "criterion"))
    with open(os.path.join(out, "criterion.txt")) as f:
        criterion_text = f.read()

    def row(name, mine, theirs, unit="s"):
        print(f"{name:<44} {mine:>10.4g} {unit:<8} {theirs:>10.4g} {unit:<8} {theirs / mine:>7.1f}x")

    def per_s_row(name, mine, theirs, unit):
        print(f"{name:<44} {mine:>10.4g} {unit:<8} {theirs:>10.4g} {unit:<8} {mine / theirs:>7.1f}x")

    print(f"{'':<44} {'mapvlm':>19} {'reference':>19} {'speed-up':>8}")
    embed = ours["mpnet/embed_64_steps"]
    per_s_row("embed 64 steps (sentences/s)", 64 / embed, ref["embed64"]["sentences_per_s"], "sent/s")
    row("score a 6x10 pair, cold", ours["score 6x10 pair/cold"], ref["pair"]["cold_s"])
    row("score a 6x10 pair, warm (one step edited)",
        ours["score 6x10 pair/warm, one step edited"], ref["pair"]["warm_s"])
    row("score 40 pairs, models loaded",
        ours["score 40 golden pairs/batched and cached, models loaded"], ref["pairs40"]["seconds"])
    words = ref["words"]["words"]
    steps = ours["en_parse/golden_steps"]
    per_s_row("parse dev sentences vs nlp.pipe (words/s)", words / steps,
              ref["words"]["pipe_words_per_s"], "words/s")
    per_s_row("parse dev sentences vs one at a time", words / steps,
              ref["words"]["one_at_a_time_words_per_s"], "words/s")
    row("whole process: score --pairs, 40 pairs", whole["mapvlm_s"], whole["reference_s"])
    with open(os.path.join(out, "whole-process-golden.json")) as f:
        golden = json.load(f)
    n = golden["pairs"]
    row(f"whole process: {n} golden pairs, cold cache", golden["mapvlm_cold_s"], golden["reference_s"])
    row(f"whole process: {n} golden pairs, warm cache", golden["mapvlm_warm_s"], golden["reference_s"])
    print(f"(warm output byte-identical to cold; load average {golden['load_average']})")
    row("score 40 pairs, models loaded, store cold",
        ours["score 40 golden pairs/embedding store cold (empty)"], ref["pairs40"]["seconds"])
    row("score 40 pairs, models loaded, store warm",
        ours["score 40 golden pairs/embedding store warm (never encodes)"], ref["pairs40"]["seconds"])

    match = re.search(r"([\d.]+) GFLOP per pass", criterion_text)
    if match:
        flops = float(match.group(1)) * 1e9 / embed
        cores, mhz, peak = peak_f32_flops()
        print(f"\nencoder: {flops / 1e9:.1f} GFLOP/s = {100 * flops / peak:.0f}% of "
              f"{peak / 1e9:.0f} GFLOP/s f32 peak ({cores} cores x {mhz:.0f} MHz x 32 FLOP/cycle)")


if __name__ == "__main__":
    main()
