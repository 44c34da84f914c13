//! `hugrt bench`: every structure on every scene, on the same work, through
//! [`hugrt::bench`]; a Markdown table on stdout, JSON and CSV on request, and an error when
//! a structure's answers differ from the first one's.

use crate::load_scene;
use anyhow::{Context, Result, bail};
use hugrt::accel::{COUNTERS, Packets};
use hugrt::bench::{BenchRow, Candidate, DEFAULT_SCENES, Workload, bench_scene, write_csv};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};

pub struct Options {
    pub scenes: Vec<String>,
    pub accels: Vec<String>,
    /// Each structure is measured with each mode.
    pub packets: Vec<Packets>,
    pub workload: Workload,
    pub repeat: usize,
    pub json: Option<PathBuf>,
    pub csv: Option<PathBuf>,
    pub quiet: bool,
}

fn short(name: &str) -> String {
    Path::new(name)
        .file_name()
        .map_or(name.to_string(), |f| f.to_string_lossy().into_owned())
}

/// Runs the benchmark on the current rayon pool.
pub fn run(o: Options) -> Result<()> {
    let scenes = if o.scenes.is_empty() {
        DEFAULT_SCENES.iter().map(|s| s.to_string()).collect()
    } else {
        o.scenes
    };
    let runs: Vec<(&String, Packets)> = o
        .accels
        .iter()
        .flat_map(|a| o.packets.iter().map(move |&p| (a, p)))
        .collect();
    let label = |(a, p): &(&String, Packets)| Candidate::label_of(a, *p, o.packets.len() > 1);
    let bar = ProgressBar::new((scenes.len() * runs.len()) as u64);
    bar.set_draw_target(if o.quiet {
        ProgressDrawTarget::hidden()
    } else {
        ProgressDrawTarget::stderr()
    });
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")?
            .progress_chars("=> "),
    );
    let mut rows: Vec<BenchRow> = Vec::new();
    for name in &scenes {
        bar.set_message(format!("{} (loading)", short(name)));
        let scene = load_scene(name)?;
        let candidates: Vec<Candidate> = runs
            .iter()
            .map(|r| Candidate {
                label: label(r),
                packets: r.1,
                ..Candidate::spec(&scene, r.0)
            })
            .collect();
        bar.set_message(format!("{} {}", short(name), label(&runs[0])));
        let mut next = 1;
        let done = &mut |_: &BenchRow| {
            bar.inc(1);
            if let Some(r) = runs.get(next) {
                bar.set_message(format!("{} {}", short(name), label(r)));
            }
            next += 1;
        };
        let r = bench_scene(
            &short(name),
            &scene,
            &candidates,
            o.workload,
            o.repeat,
            done,
        )
        .with_context(|| format!("benchmarking {name}"))?;
        rows.extend(r);
    }
    bar.finish_and_clear();
    print_table(&rows)?;
    if let Some(path) = &o.json {
        std::fs::write(path, serde_json::to_string_pretty(&rows)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &o.csv {
        let file =
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        write_csv(std::io::BufWriter::new(file), &rows)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let wrong: Vec<String> = rows
        .iter()
        .filter(|r| r.differences > 0)
        .map(|r| {
            format!(
                "{} on {}: {} {} differ",
                r.structure, r.scene, r.differences, r.compared
            )
        })
        .collect();
    if !wrong.is_empty() {
        bail!(
            "structures disagree with the first structure of their scene ({}); every structure must give the same answers",
            wrong.join("; ")
        );
    }
    Ok(())
}

/// What the table's columns mean (Havran Tables 1–3, eq. 5–6; SCG97 §3).
const SEPTET_LEGEND: &str =
    "N_C: elementary cells (grid cells that are not inner cells, a tree's leaves); R_ETNC: the
share of them holding no object; N_ADC: references per object less one; N_AOIFC: references
per cell holding any; R_FVWV: volume of those cells over the scene's; N_RPRT: ray-object tests
per hit; N_AT: cells and nodes visited per ray; T_TT/T_TR: the share of the render time spent
in the structure; then the counters per ray (SCG97 3):";

/// Counters per ray, two decimals (three below 1), joined by `sep`.
fn per_ray(c: &hugrt::bench::PerRay, sep: &str) -> String {
    let v: Vec<String> = c
        .iter()
        .map(|(_, v)| {
            if *v < 1.0 {
                format!("{v:.3}")
            } else {
                format!("{v:.2}")
            }
        })
        .collect();
    v.join(sep)
}

fn print_table(rows: &[BenchRow]) -> Result<()> {
    let names: Vec<&str> = COUNTERS.iter().map(|c| c.column).collect();
    let names = names.join(" ");
    say!(
        "| scene | prims | structure | build ms (min–max) | trace ms (min–max) | Mrays/s | B/prim | N_C | R_ETNC | N_ADC | N_AOIFC | R_FVWV | N_RPRT | N_AT | T_TT/T_TR | {names} per ray | differ |"
    );
    say!(
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    for r in rows {
        let s = &r.septet;
        let c = per_ray(&r.per_ray, " ");
        say!(
            "| {} | {} | {} | {:.1} ({:.1}–{:.1}) | {:.1} ({:.1}–{:.1}) | {:.2} | {:.1} | {} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {} | {c} | {} {} |",
            r.scene,
            r.primitives,
            r.structure,
            r.build.median_ms,
            r.build.min_ms,
            r.build.max_ms,
            r.trace.median_ms,
            r.trace.min_ms,
            r.trace.max_ms,
            r.mrays_per_s,
            r.bytes_per_primitive,
            s.n_c,
            s.r_etnc,
            s.n_adc,
            s.n_aoifc,
            s.r_fvwv,
            s.n_rprt,
            s.n_at,
            r.triplet
                .t_tt_over_t_tr
                .map_or("—".to_string(), |x| format!("{x:.2}")),
            r.differences,
            r.compared,
        );
    }
    say!();
    say!("{SEPTET_LEGEND}");
    let legend: Vec<String> = COUNTERS
        .iter()
        .map(|c| format!("{}: {}", c.column, c.help))
        .collect();
    say!("{}.", legend.join("; "));
    let deep: Vec<&BenchRow> = rows.iter().filter(|r| r.per_ray_levels.len() > 1).collect();
    if !deep.is_empty() {
        say!();
        let columns: Vec<&str> = COUNTERS.iter().map(|c| c.column).collect();
        say!("| scene | structure | level | {} |", columns.join(" | "));
        say!("| --- | --- | --- |{}", " --- |".repeat(COUNTERS.len()));
        for r in deep {
            for (l, c) in r.per_ray_levels.iter().enumerate() {
                say!(
                    "| {} | {} | {l} | {} |",
                    r.scene,
                    r.structure,
                    per_ray(c, " | ")
                );
            }
        }
    }
    Ok(())
}
