//! `mapvlm agree` as a user runs it: the golden set through the real binary
//! (point estimates to 1e-9, counts exactly), the report as a snapshot, the
//! figure in both formats, and bad input named by file and line.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

fn mapvlm(args: &[&str]) -> Output {
    common::mapvlm_command()
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("running mapvlm: {e}"))
}

fn golden(part: &str) -> String {
    common::shared()
        .join(format!("golden/agree.dev.{part}"))
        .to_string_lossy()
        .into_owned()
}

/// `agree` on these items, scores and annotations, plus `extra`.
fn agree_on(items: &str, scores: &str, annotations: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "agree",
        "--items",
        items,
        "--scores",
        scores,
        "--annotations",
        annotations,
    ];
    args.extend_from_slice(extra);
    mapvlm(&args)
}

/// `agree` on the golden items, scores and annotations, plus `extra`.
pub(crate) fn agree_golden(extra: &[&str]) -> Output {
    agree_on(
        &golden("items.jsonl"),
        &golden("scores.jsonl"),
        &golden("annotations.jsonl"),
        extra,
    )
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Every field of `expected` is in `actual`: numbers with a fraction to
/// 1e-9, whole numbers exactly, `null` as `null`.
fn assert_matches(expected: &Value, actual: &Value, path: &str) {
    match expected {
        Value::Object(fields) => {
            for (key, want) in fields {
                let got = actual
                    .get(key)
                    .unwrap_or_else(|| panic!("{path}.{key} is missing"));
                assert_matches(want, got, &format!("{path}.{key}"));
            }
        }
        Value::Number(n) if n.is_u64() || n.is_i64() => {
            assert_eq!(actual, expected, "{path}: a count must be exact");
        }
        Value::Number(n) => {
            let (want, got) = (n.as_f64().unwrap_or(f64::NAN), actual.as_f64());
            let got = got.unwrap_or_else(|| panic!("{path}: {actual} is not a number"));
            assert!((want - got).abs() <= 1e-9, "{path}: {got} != {want}");
        }
        _ => assert_eq!(actual, expected, "{path}"),
    }
}

#[test]
fn the_golden_set_gives_the_expected_document_and_nothing_else_on_stdout() {
    let out = agree_golden(&["--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let doc: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("stdout is not one JSON document: {e}"));
    let path = common::shared().join("golden/agree.dev.expected.json");
    let expected: Value = serde_json::from_str(
        &std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_matches(&expected, &doc, "agree");
    // The parts the reference leaves to the random streams are present.
    let ci = &doc["metrics"]["pg2s"]["ci95"]["kendall_tau_b"];
    let (lo, hi) = (
        ci[0].as_f64().unwrap_or(2.0),
        ci[1].as_f64().unwrap_or(-2.0),
    );
    let tau = doc["metrics"]["pg2s"]["kendall_tau_b"]
        .as_f64()
        .unwrap_or(f64::NAN);
    assert!(lo < tau && tau < hi, "{lo} < {tau} < {hi}");
    let p = doc["pg2s_vs_kas"]["p_value"].as_f64().unwrap_or(-1.0);
    assert!(p > 0.0 && p <= 1.0, "{p}");
    // The ceiling's mean rests on the items two or more annotators rated.
    assert_eq!(
        doc["human_ceiling"]["mean"]["n"],
        doc["inter_annotator"]["shared_items"]
    );
    // No pairwise judgements in the golden set: null, with the reason.
    assert_eq!(doc["pairwise"]["pg2s"]["n"], 0);
    assert_eq!(doc["pairwise"]["pg2s"]["agreement"], Value::Null);
    assert!(doc["pairwise"]["pg2s"]["reasons"]["agreement"].is_string());
    let err = text(&out.stderr);
    assert!(err.contains("\"no-such-item\""), "{err}");
    // The same seed gives the same document; another gives other intervals.
    assert_eq!(agree_golden(&["--json"]).stdout, out.stdout);
    let other: Value = serde_json::from_slice(&agree_golden(&["--json", "--seed", "9"]).stdout)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_ne!(
        other["metrics"]["pg2s"]["ci95"],
        doc["metrics"]["pg2s"]["ci95"]
    );
    assert_eq!(
        other["metrics"]["pg2s"]["kendall_tau_b"],
        doc["metrics"]["pg2s"]["kendall_tau_b"]
    );
}

/// `agree --json` of the golden set, and the values the definitional Python
/// gives for it: the fixture written by `scripts/agree_cases.py PYTHON
/// --golden-fixture` with the scipy pinned there.
fn golden_and_fixture() -> (Value, Value) {
    let out = agree_golden(&["--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/agree.golden.p_values.json");
    let fixture: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap_or_default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (doc, fixture)
}

/// `got` equals the number `want` to 1e-9 relative.
fn assert_close_relative(got: &Value, want: &Value, what: &str) {
    let want = want.as_f64().unwrap_or(f64::NAN);
    let got = got
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: {got} is not a number"));
    assert!(
        (got - want).abs() <= 1e-9 * want.abs(),
        "{what}: {got:e} != {want:e}"
    );
}

#[test]
fn p_values_of_the_golden_set_equal_scipy_to_1e_9_relative() {
    let (doc, fixture) = golden_and_fixture();
    let metrics = fixture["metrics"]
        .as_object()
        .unwrap_or_else(|| panic!("{fixture}"));
    assert_eq!(metrics.len(), 4);
    for (metric, row) in metrics {
        for statistic in ["kendall_tau_b", "spearman", "pearson"] {
            assert_close_relative(
                &doc["metrics"][metric]["p_values"][statistic],
                &row[statistic],
                &format!("{metric} {statistic}"),
            );
        }
    }
}

#[test]
fn williams_and_holm_of_the_golden_set_equal_the_definitional_python() {
    // Williams' t and p by the formula with scipy's pearsonr and t.sf, Holm
    // by its definition.
    let (doc, fixture) = golden_and_fixture();
    let (want, got) = (&fixture["williams"], &doc["williams"]);
    assert_eq!(got["holm_family"], want["holm_family"]);
    let pairs = want["pairs"]
        .as_object()
        .unwrap_or_else(|| panic!("{fixture}"));
    assert_eq!(pairs.len(), 6);
    for (pair, row) in pairs {
        assert_eq!(got["pairs"][pair]["n"], row["n"], "{pair}");
        for key in ["t", "p_value", "p_holm"] {
            assert_close_relative(
                &got["pairs"][pair][key],
                &row[key],
                &format!("{pair} {key}"),
            );
        }
    }
}

#[test]
fn the_report_of_the_golden_set() {
    let out = agree_golden(&[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    insta::assert_snapshot!("agree_report_golden", text(&out.stdout));
    // Under a locale without UTF-8 the same report, its plot drawn in ASCII.
    let c = common::mapvlm_command()
        .env_remove("LC_ALL")
        .env_remove("LC_CTYPE")
        .env("LANG", "C")
        .args([
            "agree",
            "--items",
            &golden("items.jsonl"),
            "--scores",
            &golden("scores.jsonl"),
        ])
        .args(["--annotations", &golden("annotations.jsonl")])
        .output()
        .unwrap();
    let (ascii, utf8) = (text(&c.stdout), text(&out.stdout));
    assert!(
        ascii.is_ascii() && ascii.contains(" |") && ascii.contains("+---"),
        "{ascii}"
    );
    assert_eq!(ascii.lines().count(), utf8.lines().count());
    // The human column of the corruption table says which human score it
    // compares, as --aggregate makes it.
    let median = text(&agree_golden(&["--aggregate", "median", "--bootstrap", "10"]).stdout);
    assert!(
        median.contains("Corruption detection: source higher / tied / corruption higher (of n); human: the median of an item's ratings (--aggregate median)"),
        "{median}"
    );
}

/// An SVG drawn by resvg with an empty font database, as a machine without
/// any font shows it, at `size` pixels.
fn render_without_fonts(svg: &str, size: (u32, u32)) -> image::RgbImage {
    let options = resvg::usvg::Options::default();
    assert!(options.fontdb.is_empty(), "the font database is empty");
    let tree = resvg::usvg::Tree::from_str(svg, &options).unwrap_or_else(|e| panic!("{e}"));
    let mut pixmap =
        resvg::tiny_skia::Pixmap::new(size.0, size.1).unwrap_or_else(|| panic!("a pixmap"));
    let scale = size.0 as f32 / tree.size().width();
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    let rgba = image::RgbaImage::from_raw(size.0, size.1, pixmap.take())
        .unwrap_or_else(|| panic!("the pixmap's size"));
    image::DynamicImage::ImageRgba8(rgba).to_rgb8()
}

/// The mean absolute difference of two pictures of one size, per channel,
/// as a share of 255.
fn difference(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    assert_eq!(a.dimensions(), b.dimensions());
    let sum: u64 = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| u64::from(x.abs_diff(*y)))
        .sum();
    sum as f64 / a.as_raw().len() as f64 / 255.0
}

#[test]
fn the_svg_without_fonts_looks_like_the_png() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let svg = dir.path().join("agree.svg");
    let out = agree_golden(&["--plot", &svg.to_string_lossy(), "--bootstrap", "10"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let doc = std::fs::read_to_string(&svg).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        doc.starts_with("<svg width=\"12.5000in\""),
        "{}",
        &doc[..80.min(doc.len())]
    );
    assert!(!doc.contains("<text"), "no text element needs a font");
    for label in [
        "aria-label=\"KAS\"",
        "aria-label=\"S_plan\"",
        "aria-label=\"least squares; τb = 0.198, n = 123\"",
        "aria-label=\"mean human rating\"",
        "aria-label=\"object-swap (16)\"",
        "<circle",
    ] {
        assert!(doc.contains(label), "{label:?} not in the SVG");
    }
    let png = dir.path().join("agree.png");
    let out = agree_golden(&["--plot", &png.to_string_lossy(), "--bootstrap", "10"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let picture = image::open(&png)
        .unwrap_or_else(|e| panic!("{e}"))
        .to_rgb8();
    assert_eq!(picture.dimensions(), (1200, 900));
    let d = difference(&picture, &render_without_fonts(&doc, (1200, 900)));
    assert!(d <= 0.02, "the SVG and the PNG differ by {:.2}%", d * 100.0);
    // The comparison sees text: the SVG with its text left unfilled
    // differs from the PNG by more.
    let bare = doc.replace("<path fill=\"#000000\"", "<path fill=\"none\"");
    let without_text = difference(&picture, &render_without_fonts(&bare, (1200, 900)));
    assert!(without_text > d * 1.5, "{without_text} against {d}");

    let small = dir.path().join("small.png");
    let out = agree_golden(&[
        "--plot",
        &small.to_string_lossy(),
        "--bootstrap",
        "10",
        "--size",
        "600x450",
        "--dpi",
        "48",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let shrunk = image::open(&small).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((shrunk.width(), shrunk.height()), (600, 450));
    for (flag, value, says) in [
        ("--size", "1200", "WIDTHxHEIGHT"),
        ("--size", "50x50", "200 to 10000 pixels"),
        ("--dpi", "5", "24 to 1200 dpi"),
    ] {
        let out = agree_golden(&["--plot", &small.to_string_lossy(), flag, value]);
        assert!(!out.status.success(), "{flag} {value} is refused");
        assert!(text(&out.stderr).contains(says), "{}", text(&out.stderr));
    }
    let out = agree_golden(&["--plot", &dir.path().join("agree.pdf").to_string_lossy()]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains(".svg or .png"),
        "{}",
        text(&out.stderr)
    );
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap_or_else(|e| panic!("{e}"));
    path
}

#[test]
fn bad_lines_are_named_and_the_rest_still_counts() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let items = write(
        dir.path(),
        "items.jsonl",
        concat!(
            "{\"id\": \"a\", \"gt\": [\"A.\"], \"pred\": [\"A.\"]}\n",
            "{\"id\": \"b\", \"gt\": [\"A.\"], \"pred\": [\"B.\"]}\n",
            "{\"id\": \"b~drop\", \"gt\": [\"A.\"], \"pred\": [], \"source\": \"b\", \"corruption\": {\"kind\": \"drop\", \"seed\": 1, \"edits\": []}}\n",
            "not json\n",
        ),
    );
    let scores = write(
        dir.path(),
        "scores.jsonl",
        concat!(
            "{\"id\": \"a\", \"pg2s\": 0.9, \"s_plan\": 1.0, \"s_goal\": 0.8, \"kas\": 1.0}\n",
            "{\"id\": \"b\", \"pg2s\": 0.5, \"s_plan\": 0.5, \"s_goal\": 0.5, \"kas\": null}\n",
            "{\"id\": \"b~drop\", \"pg2s\": 0.5, \"s_plan\": 0.2, \"s_goal\": 0.8, \"kas\": null}\n",
        ),
    );
    let annotations = write(
        dir.path(),
        "ann.jsonl",
        concat!(
            "{\"item\": \"a\", \"annotator\": \"ana\", \"rating\": 5, \"at\": 1}\n",
            "{\"item\": \"b\", \"annotator\": \"ana\", \"rating\": 3, \"at\": 2}\n",
            "{\"item\": \"b~drop\", \"annotator\": \"ana\", \"rating\": 1, \"at\": 3}\n",
            "{\"item\": \"a\", \"annotator\": \"ana\", \"rating\": 9, \"at\": 4}\n",
            "{\"pair\": [\"a\", \"b\"], \"annotator\": \"bo\", \"preference\": \"left\", \"at\": 5}\n",
            "{\"pair\": [\"b~drop\", \"b\"], \"annotator\": \"bo\", \"preference\": \"left\", \"at\": 6}\n",
            "{\"pair\": [\"a\", \"zz\"], \"annotator\": \"bo\", \"preference\": \"right\", \"at\": 7}\n",
        ),
    );
    let out = mapvlm(&[
        "agree",
        "--items",
        &items.to_string_lossy(),
        "--scores",
        &scores.to_string_lossy(),
        "--annotations",
        &annotations.to_string_lossy(),
        "--json",
        "--bootstrap",
        "50",
    ]);
    let err = text(&out.stderr);
    assert!(
        !out.status.success(),
        "bad lines make the exit code non-zero"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("items.jsonl:4:"), "{err}");
    assert!(
        err.contains("ann.jsonl:4:") && err.contains("rating 9"),
        "{err}"
    );
    assert!(err.contains("\"zz\""), "{err}");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(doc["items"], 3);
    assert_eq!(doc["annotators"], serde_json::json!(["ana"]));
    assert_eq!(doc["metrics"]["pg2s"]["n"], 3);
    assert_eq!(doc["metrics"]["kas"]["n"], 1);
    assert_eq!(doc["metrics"]["kas"]["kendall_tau_b"], Value::Null);
    assert_eq!(
        doc["metrics"]["kas"]["reasons"]["kendall_tau_b"],
        "fewer than two items"
    );
    assert_eq!(
        doc["inter_annotator"]["krippendorff_alpha_ordinal"],
        Value::Null
    );
    assert_eq!(doc["pg2s_vs_kas"]["p_value"], Value::Null);
    // a > b by PG2S (agrees); b~drop = b by PG2S (a tie is not agreement).
    assert_eq!(
        doc["pairwise"]["pg2s"],
        serde_json::json!({"n": 2, "agreement": 0.5})
    );
    // s_goal: 0.8 > 0.5 and 0.8 > 0.5: both agree.
    assert_eq!(doc["pairwise"]["s_goal"]["agreement"], 1.0);
    assert_eq!(doc["pairwise"]["kas"]["n"], 0);
    let drop = &doc["corruption"]["drop"];
    assert_eq!(
        drop["pg2s"],
        serde_json::json!({"n": 1, "detected": 0, "tied": 1, "reversed": 0})
    );
    assert_eq!(drop["s_goal"]["reversed"], 1);
    assert_eq!(drop["human"]["detected"], 1);
    assert!(drop.get("kas").is_none());
}

#[test]
fn without_annotations_only_the_corruption_table_is_reported() {
    let items = golden("items.jsonl");
    let scores = golden("scores.jsonl");
    let out = mapvlm(&["agree", "--items", &items, "--scores", &scores, "--json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert!(doc["metrics"].is_null(), "{doc}");
    assert_eq!(doc["reasons"]["metrics"], "no annotations given");
    assert_eq!(doc["corruption"]["reorder"]["kas"]["detected"], 8);
    let out = mapvlm(&["agree", "--items", &items, "--scores", &scores]);
    assert!(text(&out.stdout).contains("No annotations given"));
    let out = mapvlm(&[
        "agree",
        "--items",
        &items,
        "--scores",
        &scores,
        "--bootstrap",
        "100000000",
    ]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("--bootstrap"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn the_pg2s_flags_score_the_items_as_score_does_and_other_settings_are_refused() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (items, annotations) = (golden("items.jsonl"), golden("annotations.jsonl"));
    let scores = dir.path().join("scores.jsonl");
    let scored = mapvlm(&[
        "score",
        "--pairs",
        &items,
        "--json",
        "--sentence-threshold",
        "0.7",
    ]);
    assert!(scored.status.success(), "{}", text(&scored.stderr));
    std::fs::write(&scores, &scored.stdout).unwrap_or_else(|e| panic!("{e}"));
    let scores = scores.to_string_lossy().into_owned();
    let agree = |extra: &[&str]| {
        let mut args = vec![
            "agree",
            "--items",
            &items,
            "--annotations",
            &annotations,
            "--json",
            "--bootstrap",
            "50",
            "--permutations",
            "50",
        ];
        args.extend_from_slice(extra);
        mapvlm(&args)
    };
    let now = agree(&["--sentence-threshold", "0.7"]);
    assert!(now.status.success(), "{}", text(&now.stderr));
    let from_file = agree(&["--sentence-threshold", "0.7", "--scores", &scores]);
    assert!(from_file.status.success(), "{}", text(&from_file.stderr));
    assert_eq!(
        text(&now.stdout),
        text(&from_file.stdout),
        "agree scores the items with the flag exactly as score does"
    );
    let defaults = agree(&[]);
    assert!(defaults.status.success(), "{}", text(&defaults.stderr));
    assert_ne!(
        text(&defaults.stdout),
        text(&now.stdout),
        "the threshold changes the agreement"
    );

    let refused = agree(&["--scores", &scores]);
    common::assert_one_line_failure(&refused, "scores.jsonl:1:");
    assert!(
        text(&refused.stderr).contains("sentence threshold 0.7"),
        "{}",
        text(&refused.stderr)
    );
    let unrecorded = agree(&["--scores", &golden("scores.jsonl"), "--alpha", "0.4"]);
    common::assert_one_line_failure(&unrecorded, "do not record their PG2S settings");
}

/// The rows of each `tabular` of a LaTeX document, split into cells, after
/// checking that it is well-formed booktabs: balanced environments and
/// braces, and per table `\toprule`, one header row, `\midrule`, the body,
/// `\bottomrule`, every row with as many cells as the column spec says.
fn booktabs_tables(tex: &str) -> Vec<(Vec<String>, Vec<Vec<String>>)> {
    for env in ["table", "tabular"] {
        let begins = tex.matches(&format!("\\begin{{{env}}}")).count();
        assert_eq!(
            begins,
            tex.matches(&format!("\\end{{{env}}}")).count(),
            "{env}"
        );
    }
    // Braces balance once the escaped ones (\{ \}) are left out.
    let unescaped = tex.replace("\\{", "").replace("\\}", "");
    let mut depth = 0i64;
    for c in unescaped.chars() {
        depth += i64::from(c == '{') - i64::from(c == '}');
        assert!(depth >= 0, "a closing brace without its opening one");
    }
    assert_eq!(depth, 0, "unbalanced braces");
    let mut tables = Vec::new();
    for block in tex.split("\\begin{tabular}").skip(1) {
        let (spec, rest) = block
            .strip_prefix('{')
            .and_then(|b| b.split_once("}\n"))
            .unwrap_or_else(|| panic!("no column spec: {block}"));
        let columns = spec.len();
        let body = rest
            .split_once("\\end{tabular}")
            .unwrap_or_else(|| panic!("no \\end{{tabular}}"))
            .0;
        let lines: Vec<&str> = body.lines().collect();
        assert_eq!(lines.first(), Some(&"\\toprule"), "{body}");
        assert_eq!(lines.get(2), Some(&"\\midrule"), "{body}");
        assert_eq!(lines.last(), Some(&"\\bottomrule"), "{body}");
        let cells = |line: &str| -> Vec<String> {
            let row = line
                .strip_suffix(" \\\\")
                .unwrap_or_else(|| panic!("a row ends in \\\\: {line}"));
            let cells: Vec<String> = row.split(" & ").map(String::from).collect();
            assert_eq!(cells.len(), columns, "{line}");
            cells
        };
        let header = cells(lines[1]);
        let rows = lines[3..lines.len() - 1].iter().map(|l| cells(l)).collect();
        tables.push((header, rows));
    }
    tables
}

#[test]
fn the_latex_table_of_the_golden_set_is_booktabs_with_the_numbers_of_the_json() {
    let out = agree_golden(&["--table", "latex"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let tex = text(&out.stdout);
    let doc: Value =
        serde_json::from_slice(&agree_golden(&["--json"]).stdout).unwrap_or_else(|e| panic!("{e}"));
    let tables = booktabs_tables(&tex);
    assert_eq!(tables.len(), 2, "{tex}");
    let (header, rows) = &tables[0];
    assert_eq!(header[0], "Metric");
    let names: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(names, ["PG2S", "S\\_plan", "S\\_goal", "KAS"]);
    let three = |v: &Value| format!("{:.3}", v.as_f64().unwrap_or(f64::NAN));
    for (row, metric) in rows.iter().zip(["pg2s", "s_plan", "s_goal", "kas"]) {
        let m = &doc["metrics"][metric];
        assert_eq!(row[1], m["n"].to_string(), "{metric}");
        for (cell, key) in
            row[2..]
                .iter()
                .zip(["kendall_tau_b", "spearman", "pearson", "pairwise_accuracy"])
        {
            let ci = &m["ci95"][key];
            let want = format!("{} [{}, {}]", three(&m[key]), three(&ci[0]), three(&ci[1]));
            assert_eq!(cell, &want, "{metric} {key}");
        }
    }
    let (header, rows) = &tables[1];
    assert_eq!(header.last().map(String::as_str), Some("Human"));
    let kinds = doc["corruption"]
        .as_object()
        .unwrap_or_else(|| panic!("{doc}"));
    assert_eq!(rows.len(), kinds.len());
    for (row, (kind, cells)) in rows.iter().zip(kinds) {
        assert_eq!(&row[0], kind);
        for (cell, column) in row[1..]
            .iter()
            .zip(["pg2s", "s_plan", "s_goal", "kas", "human"])
        {
            let c = &cells[column];
            let want = format!(
                "{}/{}/{} of {}",
                c["detected"], c["tied"], c["reversed"], c["n"]
            );
            assert_eq!(cell, &want, "{kind} {column}");
        }
    }
    // The caption says how the human score and the human column are made.
    let z = text(&agree_golden(&["--table", "latex", "--aggregate", "z"]).stdout);
    assert!(
        z.contains("(Human: the mean of an item's ratings as per-annotator z-scores)"),
        "{z}"
    );
}

#[test]
fn the_csv_and_markdown_tables_carry_the_numbers_of_the_json() {
    let doc: Value =
        serde_json::from_slice(&agree_golden(&["--json"]).stdout).unwrap_or_else(|e| panic!("{e}"));
    let out = agree_golden(&["--table", "csv"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let csv = text(&out.stdout);
    assert!(!csv.replace("\r\n", "").contains('\n'), "CRLF line ends");
    let (correlations, corruption) = csv
        .split_once("\r\n\r\n")
        .unwrap_or_else(|| panic!("two tables: {csv}"));
    let lines: Vec<Vec<&str>> = correlations
        .lines()
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(lines[0][..3], ["Metric", "n", "kendall_tau_b"]);
    assert_eq!(lines.len(), 5);
    for (row, metric) in lines[1..].iter().zip(["pg2s", "s_plan", "s_goal", "kas"]) {
        for (cell, name) in row.iter().zip(&lines[0]).skip(2) {
            let (key, bound) = match name.rsplit_once('_') {
                Some((key, "low")) => (key, Some(0)),
                Some((key, "high")) => (key, Some(1)),
                _ => (*name, None),
            };
            let m = &doc["metrics"][metric];
            let want = match bound {
                Some(b) => &m["ci95"][key][b],
                None => &m[key],
            };
            let got: f64 = cell.parse().unwrap_or_else(|e| panic!("{cell}: {e}"));
            assert_eq!(Some(got), want.as_f64(), "{metric} {name}: every digit");
        }
    }
    assert!(corruption.starts_with("Kind,Column,n,detected,tied,reversed\r\n"));
    assert!(corruption.contains("\r\nreorder,Human,"), "{corruption}");
    let md = text(&agree_golden(&["--table", "md"]).stdout);
    let rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| ")).collect();
    assert_eq!(
        rows.len(),
        2 + 4 + doc["corruption"].as_object().map_or(0, |c| c.len())
    );
    let pg2s = &doc["metrics"]["pg2s"];
    assert!(
        rows[1].starts_with(&format!(
            "| PG2S | {} | {:.3} [",
            pg2s["n"],
            pg2s["kendall_tau_b"].as_f64().unwrap_or(f64::NAN)
        )),
        "{md}"
    );
    // --table and --json are one or the other.
    let both = agree_golden(&["--table", "md", "--json"]);
    assert!(!both.status.success());
}

#[test]
fn judgements_under_several_guidelines_are_named_and_one_can_be_kept() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (mut items, mut scores) = (String::new(), String::new());
    for (i, id) in ["a", "b", "c", "d"].iter().enumerate() {
        items += &format!("{{\"id\": \"{id}\", \"gt\": [\"A.\"], \"pred\": [\"B.\"]}}\n");
        let v = i as f64 / 4.0;
        scores += &format!(
            "{{\"id\": \"{id}\", \"pg2s\": {v}, \"s_plan\": {v}, \"s_goal\": {v}, \"kas\": {v}}}\n"
        );
    }
    let items = write(dir.path(), "items.jsonl", &items);
    let scores = write(dir.path(), "scores.jsonl", &scores);
    // ana judged under guidelines aaaa1111 (her line for d superseded under
    // bbbb2222), bo under bbbb2222; bo's lines carry no `at`, as lines from
    // another tool may not.
    let annotations = write(
        dir.path(),
        "ann.jsonl",
        concat!(
            "{\"item\": \"a\", \"annotator\": \"ana\", \"rating\": 1, \"at\": 1, \"guidelines\": \"aaaa1111\"}\n",
            "{\"item\": \"b\", \"annotator\": \"ana\", \"rating\": 2, \"at\": 2, \"guidelines\": \"aaaa1111\"}\n",
            "{\"item\": \"c\", \"annotator\": \"ana\", \"rating\": 4, \"at\": 3, \"guidelines\": \"aaaa1111\"}\n",
            "{\"item\": \"d\", \"annotator\": \"ana\", \"rating\": 5, \"at\": 4, \"guidelines\": \"aaaa1111\"}\n",
            "{\"item\": \"d\", \"annotator\": \"ana\", \"rating\": 4, \"at\": 5, \"guidelines\": \"bbbb2222\"}\n",
            "{\"item\": \"b\", \"annotator\": \"bo\", \"rating\": 3, \"guidelines\": \"bbbb2222\"}\n",
            "{\"item\": \"c\", \"annotator\": \"bo\", \"rating\": 5, \"guidelines\": \"bbbb2222\"}\n",
        ),
    );
    let run = |extra: &[&str]| {
        let mut args = vec!["--json", "--bootstrap", "20", "--permutations", "20"];
        args.extend_from_slice(extra);
        agree_on(
            &items.to_string_lossy(),
            &scores.to_string_lossy(),
            &annotations.to_string_lossy(),
            &args,
        )
    };
    // Pooled: one warning naming both hashes, with the current judgements
    // made under each, and how to keep one; the lines without `at` count.
    let out = run(&[]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    let warning = "judgements made under 2 guidelines are pooled, by hash: aaaa1111 (3), bbbb2222 (3); keep one with --guidelines-hash HASH";
    assert_eq!(err.matches(warning).count(), 1, "{err}");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(doc["items"], 4);
    assert_eq!(doc["annotators"], serde_json::json!(["ana", "bo"]));
    assert!(doc["warnings"]
        .as_array()
        .is_some_and(|w| w.contains(&warning.into())));
    // One hash kept: only its current judgements (ana's superseded line for
    // d stays superseded), and no warning.
    let out = run(&["--guidelines-hash", "aaaa1111"]);
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("pooled"), "{err}");
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        (&doc["items"], &doc["annotators"]),
        (&3.into(), &serde_json::json!(["ana"]))
    );
    let doc: Value = serde_json::from_slice(&run(&["--guidelines-hash", "bbbb2222"]).stdout)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(doc["items"], 3);
    assert_eq!(doc["annotators"], serde_json::json!(["ana", "bo"]));
    // A hash nobody judged under: one line saying which there are.
    let out = run(&["--guidelines-hash", "cccc3333"]);
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("--guidelines-hash cccc3333: no current judgement was made under it; the hashes present are aaaa1111 (3), bbbb2222 (3)"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}
