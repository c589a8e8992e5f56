//! `indoorloc study all`: every study, one after the other, and their headline figures beside
//! the figures the docs record (`recorded.toml`), so that drift shows before it ships.
//!
//! Each study runs in a process of its own (this same executable, `study NAME --json`): the
//! place study holds about 10 GB that only a process exit gives back in full, a study that
//! fails leaves the others' figures standing, and each study's own JSON is kept as
//! `DIR/NAME.json` beside its report in `DIR/NAME/`.

use crate::output::{print_json, print_text};
use crate::{Context, Result, bail};
use clap::Args;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// The studies, in the order they run.
const STUDIES: [&str; 9] = [
    "markers-distance",
    "cuts",
    "sequence",
    "track",
    "render-types",
    "robustness",
    "real",
    "synth-to-real",
    "place-split",
];

/// Arguments of `indoorloc study all`.
#[derive(Args, Debug)]
pub struct AllConfig {
    /// Every study at its `--quick` scale (the recorded figures are the quick ones).
    #[arg(long)]
    quick: bool,
    /// Folder of the studies' folders and JSON.
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-all")]
    out: PathBuf,
    /// The real dataset of `study real` and `study synth-to-real` (default: the shared 7-Scenes
    /// kitchen frames).
    #[arg(long, value_name = "DATASET")]
    data: Option<PathBuf>,
    /// Only these studies (comma-separated names).
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
    /// The `indoorloc` binary each study runs in, as its own process (default: this program,
    /// which is that binary when run from the command line; a program that calls this library
    /// names it).
    #[arg(long, value_name = "FILE", hide = true)]
    program: Option<PathBuf>,
}

/// A figure the docs record, and where to find it in a study's JSON.
#[derive(Debug, Deserialize)]
struct Recorded {
    study: String,
    /// What the figure is, in words.
    label: String,
    /// The row whose key holds the figure: every `key = value` here must match.
    #[serde(default)]
    row: toml::Table,
    /// The row's key (or the output's own key, when `row` is empty).
    key: String,
    /// The quick run's figure as the docs give it.
    value: f64,
    /// Largest difference that is not drift (absolute).
    tolerance: f64,
    /// Where the docs give it.
    doc: String,
}

#[derive(Debug, Deserialize)]
struct RecordedFile {
    figure: Vec<Recorded>,
}

/// One line of the comparison.
#[derive(Debug, Serialize)]
struct FigureRow {
    study: String,
    label: String,
    recorded: Option<f64>,
    now: Option<f64>,
    tolerance: Option<f64>,
    drift: bool,
    doc: String,
}

/// One study's run.
#[derive(Debug, Serialize)]
struct StudyRun {
    study: String,
    minutes: f64,
    /// Why it failed, when it did.
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<String>,
}

#[derive(Debug, Serialize)]
struct AllOutput {
    quick: bool,
    studies: Vec<StudyRun>,
    figures: Vec<FigureRow>,
    minutes: f64,
}

/// The recorded quick figures.
fn recorded() -> Result<Vec<Recorded>> {
    let file: RecordedFile = toml::from_str(include_str!("recorded.toml"))
        .context("the recorded figures (study/recorded.toml) do not parse")?;
    Ok(file.figure)
}

/// Runs `indoorloc study all`.
pub fn run(args: &AllConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let unknown: Vec<&String> = args
        .only
        .iter()
        .filter(|s| !STUDIES.contains(&s.as_str()))
        .collect();
    if !unknown.is_empty() {
        bail!("unknown studies {unknown:?}; the studies are {STUDIES:?}");
    }
    let chosen: Vec<&str> = STUDIES
        .iter()
        .copied()
        .filter(|s| args.only.is_empty() || args.only.iter().any(|o| o == s))
        .collect();
    let recorded = recorded()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let exe = match &args.program {
        Some(program) => program.clone(),
        None => std::env::current_exe().context("cannot find this program's own executable")?,
    };
    let start = Instant::now();
    let mut runs = Vec::new();
    let mut figures = Vec::new();
    for study in chosen {
        if !args.json {
            crate::progress::note(&format!("study {study} …"));
        }
        let t = Instant::now();
        let outcome = run_one(&exe, study, args);
        let minutes = t.elapsed().as_secs_f64() / 60.0;
        let (value, error) = match outcome {
            Ok(v) => (Some(v), None),
            Err(e) => (None, Some(format!("{e:#}"))),
        };
        if let (false, Some(e)) = (args.json, &error) {
            crate::progress::note(&format!("study {study} failed: {e}"));
        }
        runs.push(StudyRun {
            study: study.into(),
            minutes,
            error,
        });
        let mine: Vec<&Recorded> = recorded.iter().filter(|r| r.study == study).collect();
        for r in mine {
            let now = value.as_ref().and_then(|v| figure(v, r));
            let recorded = args.quick.then_some(r.value);
            figures.push(FigureRow {
                study: study.into(),
                label: r.label.clone(),
                recorded,
                now,
                tolerance: args.quick.then_some(r.tolerance),
                drift: match (recorded, now) {
                    (Some(a), Some(b)) => (a - b).abs() > r.tolerance,
                    (Some(_), None) => true,
                    _ => false,
                },
                doc: r.doc.clone(),
            });
        }
    }
    let out = AllOutput {
        quick: args.quick,
        studies: runs,
        figures,
        minutes: start.elapsed().as_secs_f64() / 60.0,
    };
    if args.json {
        print_json(sink, &out)?;
    } else {
        print_text(sink, &table(&out))?;
    }
    let drifted = out.figures.iter().filter(|f| f.drift).count();
    let failed = out.studies.iter().filter(|s| s.error.is_some()).count();
    if drifted + failed > 0 {
        bail!("{failed} studies failed and {drifted} figures drifted from the recorded ones");
    }
    Ok(())
}

/// Runs one study as its own process and reads its JSON (kept as `DIR/NAME.json`).
fn run_one(exe: &Path, study: &str, args: &AllConfig) -> Result<serde_json::Value> {
    let mut cmd = Command::new(exe);
    cmd.args(["study", study, "--json", "--out"])
        .arg(args.out.join(study));
    if args.quick {
        cmd.arg("--quick");
    }
    if study == "real" || study == "synth-to-real" {
        let data = match &args.data {
            Some(d) => d.clone(),
            None => {
                crate::bench::shared_data("data/7scenes_redkitchen_seq01", "seq-01", Path::is_dir)
                    .context("no kitchen frames beside the checkout: pass --data")?
            }
        };
        cmd.arg("--data").arg(data);
    }
    let output = cmd
        .stdin(Stdio::null())
        .stderr(Stdio::inherit())
        .output()
        .with_context(|| format!("cannot start study {study}"))?;
    if !output.status.success() {
        bail!("study {study} exited with {}", output.status);
    }
    let path = args.out.join(format!("{study}.json"));
    report::write_atomic(&path, &output.stdout)?;
    serde_json::from_slice(&output.stdout)
        .with_context(|| format!("study {study} printed no JSON document"))
}

/// The recorded figure's value in a study's output: `key` of the first row matching `row`,
/// or of the output itself when `row` is empty.
fn figure(out: &serde_json::Value, r: &Recorded) -> Option<f64> {
    if r.row.is_empty() {
        return out.get(&r.key)?.as_f64();
    }
    let matches = |row: &serde_json::Value| {
        r.row.iter().all(|(k, v)| match (row.get(k), v) {
            (Some(serde_json::Value::String(a)), toml::Value::String(b)) => a == b,
            (Some(a), toml::Value::Float(b)) => a.as_f64() == Some(*b),
            (Some(a), toml::Value::Integer(b)) => a.as_i64() == Some(*b),
            _ => false,
        })
    };
    out.get("rows")?
        .as_array()?
        .iter()
        .find(|row| matches(row))?
        .get(&r.key)?
        .as_f64()
}

fn table(out: &AllOutput) -> String {
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    let mut s = format!(
        "{:<18}{:<52}{:>10}{:>10}{:>8}  {}\n",
        "study", "figure", "recorded", "now", "", "where"
    );
    for f in &out.figures {
        s.push_str(&format!(
            "{:<18}{:<52}{:>10}{:>10}{:>8}  {}\n",
            f.study,
            f.label,
            opt(f.recorded),
            opt(f.now),
            if f.drift { "DRIFT" } else { "" },
            f.doc
        ));
    }
    s.push('\n');
    for r in &out.studies {
        s.push_str(&format!(
            "{:<18}{:>6.1} min{}\n",
            r.study,
            r.minutes,
            r.error
                .as_ref()
                .map_or(String::new(), |e| format!("  failed: {e}"))
        ));
    }
    s.push_str(&format!("all {:.1} min\n", out.minutes));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_recorded_figures_parse_and_name_known_studies() {
        let r = recorded().unwrap();
        assert!(!r.is_empty());
        for f in &r {
            assert!(STUDIES.contains(&f.study.as_str()), "{}", f.study);
            assert!(f.tolerance > 0.0 && f.value.is_finite(), "{}", f.label);
        }
    }

    #[test]
    fn figures_are_found_by_row_and_key() {
        let out = serde_json::json!({
            "frames": 300,
            "rows": [
                {"model": "single", "median_pos_m": 0.5},
                {"model": "sequence", "median_pos_m": 0.3},
            ],
        });
        let rec = |row: &str, key: &str| Recorded {
            study: "sequence".into(),
            label: String::new(),
            row: toml::from_str(row).unwrap(),
            key: key.into(),
            value: 0.0,
            tolerance: 1.0,
            doc: String::new(),
        };
        assert_eq!(
            figure(&out, &rec("model = 'sequence'", "median_pos_m")),
            Some(0.3)
        );
        assert_eq!(figure(&out, &rec("", "frames")), Some(300.0));
        assert_eq!(figure(&out, &rec("model = 'lstm'", "median_pos_m")), None);
    }
}
