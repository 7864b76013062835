//! The paper's Table 3 of an eval run's results, as Markdown and CSV: the
//! one writer of `OUT/table3.md` and `OUT/table3.csv`, for `eval` and `merge`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use super::{write_file, EvalRecordError, TaskResult};
use crate::agents::Approach;
use crate::sanitize::csv_field;
use crate::stats::summary::{self, Spread};

fn cell(value: Option<f64>, digits: usize) -> String {
    value.map_or_else(String::new, |v| format!("{v:.digits$}"))
}

/// The mean of the values present, if any.
fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let present: Vec<f64> = values.flatten().collect();
    summary::mean(&present).ok()
}

/// Sorts `results` by task (in the order of `task_ids`, the dataset's) and
/// approach, and writes the tables of [`tables`] as `OUT/table3.md` and
/// `OUT/table3.csv`: the one writer of the tables, for `eval` and `merge`.
pub fn write_tables(
    out: &Path,
    task_ids: &[String],
    approaches: &[Approach],
    results: &mut [TaskResult],
) -> Result<(), EvalRecordError> {
    results.sort_by_key(|r| {
        let task = task_ids.iter().position(|id| *id == r.id);
        let approach = approaches.iter().position(|a| *a == r.approach);
        (task, approach, r.sample)
    });
    let (markdown, csv) = tables(task_ids, approaches, results);
    write_file(&out.join("table3.md"), markdown.as_bytes())?;
    write_file(&out.join("table3.csv"), csv.as_bytes())?;
    Ok(())
}

/// The paper's Table 3: a row per task (in the order of `task_ids`), PG2S
/// and KAS for each approach, and the means; as Markdown and as CSV.
pub fn tables(
    task_ids: &[String],
    approaches: &[Approach],
    results: &[TaskResult],
) -> (String, String) {
    if results.is_empty() {
        return (String::from("No plans were scored.\n"), String::new());
    }
    let samples = results.iter().map(|r| r.sample + 1).max().unwrap_or(1);
    if samples > 1 {
        return sampled_tables(task_ids, approaches, results, samples);
    }
    let find = |id: &str, approach: Approach| {
        results
            .iter()
            .find(|r| r.id == id && r.approach == approach)
    };
    let mut markdown = markdown_heading(approaches);
    let mut csv = String::from("id,task");
    for approach in approaches {
        let _ = write!(csv, ",{approach}_pg2s,{approach}_kas");
    }
    csv.push('\n');
    for id in task_ids {
        let Some(first) = approaches.iter().find_map(|a| find(id, *a)) else {
            continue;
        };
        let _ = write!(markdown, "| {id} | {} |", first.task.replace('|', "\\|"));
        let _ = write!(csv, "{},{}", csv_field(id), csv_field(&first.task));
        for approach in approaches {
            let result = find(id, *approach);
            let (pg2s, kas) = (result.and_then(|r| r.pg2s), result.and_then(|r| r.kas));
            push_scores(&mut markdown, &mut csv, pg2s, kas, "");
        }
        markdown.push('\n');
        csv.push('\n');
    }
    let _ = write!(markdown, "| **Mean** | |");
    csv.push_str("mean,");
    for approach in approaches {
        let of = |r: &&TaskResult| r.approach == *approach;
        let pg2s = mean(results.iter().filter(of).map(|r| r.pg2s));
        let kas = mean(results.iter().filter(of).map(|r| r.kas));
        push_scores(&mut markdown, &mut csv, pg2s, kas, "**");
    }
    markdown.push('\n');
    csv.push('\n');
    (markdown, csv)
}

/// One score Table 3 reports: its heading, its CSV column and its value.
struct Score {
    label: &'static str,
    column: &'static str,
    of: fn(&TaskResult) -> Option<f64>,
}

/// The scores whose spread over samples the tables show.
const SCORES: [Score; 4] = [
    Score::new("PG2S", "pg2s", |r| r.pg2s),
    Score::new("S_plan", "s_plan", |r| r.s_plan),
    Score::new("S_goal", "s_goal", |r| r.s_goal),
    Score::new("KAS", "kas", |r| r.kas),
];

impl Score {
    const fn new(
        label: &'static str,
        column: &'static str,
        of: fn(&TaskResult) -> Option<f64>,
    ) -> Self {
        Score { label, column, of }
    }
}

/// Table 3 over several samples of each plan. Markdown: each task's PG2S
/// and KAS as the mean ±sd of its samples; the Mean row and a spread table
/// over the samples' means (each sample's mean over the tasks: mean ±sd and
/// min–max of PG2S, S_plan, S_goal and KAS). CSV: for each approach and
/// score its mean, sd, min and max, per task over its samples and, in the
/// `mean` row, over the samples' means.
fn sampled_tables(
    task_ids: &[String],
    approaches: &[Approach],
    results: &[TaskResult],
    samples: u32,
) -> (String, String) {
    let mut by_plan: HashMap<(&str, Approach), Vec<&TaskResult>> = HashMap::new();
    for result in results {
        by_plan
            .entry((result.id.as_str(), result.approach))
            .or_default()
            .push(result);
    }
    let spread_of = |plans: &[&TaskResult], score: &Score| {
        Spread::of(plans.iter().filter_map(|r| (score.of)(r)))
    };
    let over_samples = |approach: Approach, score: &Score| {
        Spread::of((0..samples).filter_map(|k| {
            mean(
                results
                    .iter()
                    .filter(|r| r.approach == approach && r.sample == k)
                    .map(score.of),
            )
        }))
    };
    let [pg2s, _, _, kas] = &SCORES;
    let mut markdown = markdown_heading(approaches);
    let mut csv = String::from("id,task");
    for approach in approaches {
        for score in &SCORES {
            let c = score.column;
            let _ = write!(
                csv,
                ",{approach}_{c},{approach}_{c}_sd,{approach}_{c}_min,{approach}_{c}_max"
            );
        }
    }
    csv.push('\n');
    for id in task_ids {
        let Some(first) = approaches
            .iter()
            .find_map(|a| by_plan.get(&(id.as_str(), *a)).and_then(|p| p.first()))
        else {
            continue;
        };
        let _ = write!(markdown, "| {id} | {} |", first.task.replace('|', "\\|"));
        let _ = write!(csv, "{},{}", csv_field(id), csv_field(&first.task));
        for approach in approaches {
            let plans = by_plan
                .get(&(id.as_str(), *approach))
                .map_or(&[][..], Vec::as_slice);
            for score in [pg2s, kas] {
                let _ = write!(markdown, " {} |", spread_cell(spread_of(plans, score), ""));
            }
            for score in &SCORES {
                push_spread_csv(&mut csv, spread_of(plans, score));
            }
        }
        markdown.push('\n');
        csv.push('\n');
    }
    let _ = write!(markdown, "| **Mean** | |");
    csv.push_str("mean,");
    for approach in approaches {
        for score in [pg2s, kas] {
            let cell = spread_cell(over_samples(*approach, score), "**");
            let _ = write!(markdown, " {cell} |");
        }
        for score in &SCORES {
            push_spread_csv(&mut csv, over_samples(*approach, score));
        }
    }
    let _ = write!(
        markdown,
        "\n\nSpread over {samples} samples (each sample's mean over the tasks): mean ±sd (min–max).\n\n| Approach |"
    );
    for score in &SCORES {
        let _ = write!(markdown, " {} |", score.label);
    }
    markdown.push_str("\n| --- |");
    markdown.push_str(&" ---: |".repeat(SCORES.len()));
    markdown.push('\n');
    for approach in approaches {
        let _ = write!(markdown, "| {approach} |");
        for score in &SCORES {
            let cell = over_samples(*approach, score).map_or_else(
                || "n/a".to_string(),
                |s| format!("{} ({})", s.plus_minus(3), s.range(3)),
            );
            let _ = write!(markdown, " {cell} |");
        }
        markdown.push('\n');
    }
    csv.push('\n');
    (markdown, csv)
}

/// The heading and rule of Table 3 in Markdown: the task, its
/// instruction, then PG2S and KAS of each approach.
fn markdown_heading(approaches: &[Approach]) -> String {
    let mut markdown = String::from("| Task | Instruction |");
    let mut rule = String::from("| --- | --- |");
    for approach in approaches {
        let _ = write!(markdown, " {approach} PG2S | {approach} KAS |");
        rule.push_str(" ---: | ---: |");
    }
    let _ = writeln!(markdown, "\n{rule}");
    markdown
}

/// A Markdown cell: `0.433 ±0.020`, emphasised, or `n/a`.
fn spread_cell(spread: Option<Spread>, emphasis: &str) -> String {
    spread.map_or_else(
        || format!("{emphasis}n/a{emphasis}"),
        |s| format!("{emphasis}{}{emphasis}", s.plus_minus(3)),
    )
}

/// Appends a spread's mean, sd, min and max as four CSV cells (empty when
/// unknown).
fn push_spread_csv(csv: &mut String, spread: Option<Spread>) {
    let (mean, sd, min, max) = match spread {
        Some(s) => (Some(s.mean), s.sd, Some(s.min), Some(s.max)),
        None => (None, None, None, None),
    };
    let _ = write!(
        csv,
        ",{},{},{},{}",
        cell(mean, 6),
        cell(sd, 6),
        cell(min, 6),
        cell(max, 6)
    );
}

/// Appends one approach's PG2S and KAS cells to both tables.
fn push_scores(
    markdown: &mut String,
    csv: &mut String,
    pg2s: Option<f64>,
    kas: Option<f64>,
    emphasis: &str,
) {
    let (p, k) = (or_na(cell(pg2s, 3)), or_na(cell(kas, 3)));
    let _ = write!(
        markdown,
        " {emphasis}{p}{emphasis} | {emphasis}{k}{emphasis} |"
    );
    let _ = write!(csv, ",{},{}", cell(pg2s, 6), cell(kas, 6));
}

fn or_na(text: String) -> String {
    if text.is_empty() {
        "n/a".into()
    } else {
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scored(
        id: &str,
        approach: Approach,
        sample: u32,
        pg2s: f64,
        kas: Option<f64>,
    ) -> TaskResult {
        TaskResult {
            id: id.into(),
            approach,
            task: format!("Task {id}, with a comma"),
            source: "model".into(),
            ground_truth: vec!["Walk to the sink.".into()],
            steps: vec!["Walk to the sink.".into()],
            kas,
            kas_reason: None,
            pg2s_scored: true,
            s_plan: Some(pg2s + 0.1),
            s_goal: Some(pg2s - 0.1),
            pg2s: Some(pg2s),
            record: None,
            cost: None,
            sample,
            provenance: None,
        }
    }

    fn one_sample_results() -> Vec<TaskResult> {
        vec![
            scored("t1", Approach::SingleImage, 0, 0.5, Some(0.25)),
            scored("t1", Approach::MultiImage, 0, 0.625, None),
            scored("t2", Approach::SingleImage, 0, 0.375, Some(0.75)),
        ]
    }

    #[test]
    fn tables_of_one_sample_are_as_before_samples() {
        let ids = ["t1".to_string(), "t2".to_string()];
        let approaches = [Approach::SingleImage, Approach::MultiImage];
        let (markdown, csv) = tables(&ids, &approaches, &one_sample_results());
        insta::assert_snapshot!("table3_one_sample_md", markdown);
        insta::assert_snapshot!("table3_one_sample_csv", csv);
    }

    #[test]
    fn tables_of_three_samples_show_each_tasks_spread_and_the_samples_spread() {
        let ids = ["t1".to_string(), "t2".to_string()];
        let approaches = [Approach::SingleImage];
        let mut results = Vec::new();
        for (sample, (first, second)) in [(0.5, 0.25), (0.625, 0.375), (0.75, 0.5)]
            .into_iter()
            .enumerate()
        {
            let sample = sample as u32;
            results.push(scored(
                "t1",
                Approach::SingleImage,
                sample,
                first,
                Some(first),
            ));
            results.push(scored("t2", Approach::SingleImage, sample, second, None));
        }
        let (markdown, csv) = tables(&ids, &approaches, &results);
        // t1's PG2S over its samples: 0.5, 0.625, 0.75 -> mean 0.625, sd 0.125.
        assert!(
            markdown.contains("| t1 | Task t1, with a comma | 0.625 ±0.125 | 0.625 ±0.125 |"),
            "{markdown}"
        );
        // The samples' means over the tasks: 0.375, 0.5, 0.625.
        assert!(
            markdown.contains("| **Mean** | | **0.500 ±0.125** | **0.625 ±0.125** |"),
            "{markdown}"
        );
        assert!(markdown.contains("| single-image | 0.500 ±0.125 (0.375–0.625) | 0.600 ±0.125 (0.475–0.725) | 0.400 ±0.125 (0.275–0.525) | 0.625 ±0.125 (0.500–0.750) |"), "{markdown}");
        let lines: Vec<&str> = csv.lines().collect();
        assert!(lines[0].starts_with("id,task,single-image_pg2s,single-image_pg2s_sd,single-image_pg2s_min,single-image_pg2s_max,single-image_s_plan,"), "{csv}");
        assert!(
            lines[1]
                .starts_with("t1,\"Task t1, with a comma\",0.625000,0.125000,0.500000,0.750000,"),
            "{csv}"
        );
        assert!(lines[2].ends_with(",,,,"), "t2 has no KAS: {csv}");
        assert!(
            lines[3].starts_with("mean,,0.500000,0.125000,0.375000,0.625000,"),
            "{csv}"
        );
    }
}
