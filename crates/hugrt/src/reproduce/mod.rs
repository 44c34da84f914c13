//! The papers' experiments regenerated (`hugrt reproduce`): each target runs one table or
//! figure of the four papers on today's machine and writes, in a folder of its own, a report
//! that puts the published figures beside today's, and the data as CSV and JSON.
//!
//! The papers' scenes are not available; the generated stand-ins of [`crate::scene::generate`]
//! take their place (mission map §4), and a report says which stands in for which.

mod eg95;
mod havran;
mod plot;
mod published;
mod scg97;

use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One experiment of the papers.
pub struct Target {
    pub name: &'static str,
    /// What it regenerates, with the paper's figure or table.
    pub what: &'static str,
    run: fn(&Options) -> Output,
}

/// How a target runs.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Smaller scenes and images, for a first look and for tests.
    pub quick: bool,
    /// Where the SPD scenes are (`NAME.nff.gz`); targets that need them say so in their
    /// report when they are absent.
    pub spd_dir: PathBuf,
    /// The hugrt binary, for targets that run it under a tool (cachegrind); without it they
    /// say in their report what they could not measure.
    pub hugrt_exe: Option<PathBuf>,
}

/// What a target writes: file name and contents.
struct Output {
    files: Vec<(&'static str, String)>,
    plots: Vec<plot::Plot>,
}

/// Every target, in the papers' order.
pub const TARGETS: &[Target] = &[
    Target {
        name: "eg95-kitchens",
        what: "EG95 Figs. 11-13: render time, memory and voxels per item against polygons, one kitchen of growing detail and buildings of 2-8 kitchens; octree and recursive grid at MAXP 50/100/150 against the HUG",
        run: eg95::eg95_kitchens,
    },
    Target {
        name: "scg97-scenes",
        what: "SCG97 Fig. 4: the test scenes' statistics (objects, min/max, min/diag, %.2) and the distribution of object lengths",
        run: scg97::scg97_scenes,
    },
    Target {
        name: "scg97-levels",
        what: "SCG97 Figs. 12-23: per level of the uniform grid, the HUG and the recursive grid on the kitchen, resources, occupancy and rendering counters from two viewpoints",
        run: scg97::scg97_levels,
    },
    Target {
        name: "scg97-improved",
        what: "SCG97 section 7.5: the two-level-filter HUG with a tuned world grid against the recursive grid, at MAXP 50 and at equal memory",
        run: scg97::scg97_improved,
    },
    Target {
        name: "havran-splits",
        what: "Havran 1997 Tables 4-6: how often the optimal plane lies outside the median interval; the septet and triplet of the mid-point split against the SAH with empty space cut off",
        run: havran::havran_splits,
    },
    Target {
        name: "havran-layouts",
        what: "Havran 1997 Tables 7-8: the kd-tree's layouts in memory, their trace time and their cache behaviour under cachegrind with Havran's simulated cache",
        run: havran::havran_layouts,
    },
    Target {
        name: "rtnews-spd",
        what: "RTNews' table: uniform grid D = 1 and D = 20, recursive grid, HUG and adaptive grid on the SPD scenes, 513², depth 4",
        run: rtnews_spd,
    },
];

#[derive(Debug, thiserror::Error)]
pub enum ReproduceError {
    #[error("unknown target '{0}'; targets: {1}")]
    UnknownTarget(String, String),
    #[error("writing {0}: {1}")]
    Write(PathBuf, std::io::Error),
}

/// The targets named, in the order given; `all` stands for every target. An error names the
/// valid targets for a name that is none of them, before any work.
pub fn resolve<S: AsRef<str>>(names: &[S]) -> Result<Vec<&'static Target>, ReproduceError> {
    if names.iter().any(|n| n.as_ref() == "all") {
        return Ok(TARGETS.iter().collect());
    }
    names.iter().map(|n| target(n.as_ref())).collect()
}

fn target(name: &str) -> Result<&'static Target, ReproduceError> {
    TARGETS.iter().find(|t| t.name == name).ok_or_else(|| {
        let mut valid: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
        valid.push("all");
        ReproduceError::UnknownTarget(name.to_string(), valid.join(", "))
    })
}

/// Runs the target `name` and writes its files to `dir/name/`; returns that folder.
pub fn run(name: &str, options: &Options, dir: &Path) -> Result<PathBuf, ReproduceError> {
    let target = target(name)?;
    let out = dir.join(target.name);
    std::fs::create_dir_all(&out).map_err(|e| ReproduceError::Write(out.clone(), e))?;
    let output = (target.run)(options);
    let plots = output.plots.iter().flat_map(|p| p.render());
    let files = output
        .files
        .into_iter()
        .map(|(f, text)| (f.to_string(), text.into_bytes()));
    for (file, bytes) in files.chain(plots) {
        let path = out.join(file);
        std::fs::write(&path, bytes).map_err(|e| ReproduceError::Write(path.clone(), e))?;
    }
    Ok(out)
}

/// Writes `dir/index.html`: a section per target folder found in `dir` (in [`TARGETS`]' order),
/// linking its report and data and showing its SVG plots; returns the page's path. Targets
/// not run are left out, so the page lists what the folder holds.
pub fn write_index(dir: &Path) -> Result<PathBuf, ReproduceError> {
    let escape = |t: &str| {
        t.replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
    };
    let mut html = String::from(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>hugrt \
         reproduce</title>\n<style>body{font-family:sans-serif;max-width:60em;margin:auto}\
         img{max-width:100%;border:1px solid #ccc}</style>\n</head>\n<body>\n<h1>The papers' \
         experiments, regenerated</h1>\n",
    );
    for t in TARGETS {
        let folder = dir.join(t.name);
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        let mut files: Vec<String> = entries
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .collect();
        files.sort();
        let _ = writeln!(
            html,
            "<h2 id=\"{0}\">{0}</h2>\n<p>{1}</p>\n<p>",
            t.name,
            escape(t.what)
        );
        for f in files.iter().filter(|f| !f.ends_with(".svg")) {
            let _ = writeln!(html, "<a href=\"{}/{f}\">{f}</a>", t.name);
        }
        html.push_str("</p>\n");
        for f in files.iter().filter(|f| f.ends_with(".svg")) {
            let _ = writeln!(html, "<p><img src=\"{}/{f}\" alt=\"{f}\"></p>", t.name);
        }
    }
    html.push_str("</body>\n</html>\n");
    let path = dir.join("index.html");
    std::fs::create_dir_all(dir).map_err(|e| ReproduceError::Write(dir.to_path_buf(), e))?;
    std::fs::write(&path, html).map_err(|e| ReproduceError::Write(path.clone(), e))?;
    Ok(path)
}

/// The SPD scenes of RTNews' table, in its order.
const RTNEWS_SCENES: [&str; 8] = [
    "balls", "gears", "lattice", "mount", "rings", "teapot", "tetra", "tree",
];
/// RTNews' table as published (`data/published/rtnews-table.csv`): per structure, its label,
/// its hugrt spec, and `T_B` and `T_TR` in seconds on [`RTNEWS_SCENES`].
fn rtnews_table() -> Vec<(String, String, [f64; 8], [f64; 8])> {
    let table = published::Table::load("rtnews-table.csv");
    let mut out: Vec<(String, String, [f64; 8], [f64; 8])> = Vec::new();
    for r in table.rows() {
        let label = r.text("structure");
        if out.last().is_none_or(|o| o.0 != label) {
            out.push((
                label.to_string(),
                r.text("spec").to_string(),
                [0.0; 8],
                [0.0; 8],
            ));
        }
        let k = RTNEWS_SCENES
            .iter()
            .position(|s| *s == r.text("scene"))
            .expect("an RTNews scene");
        let last = out.last_mut().expect("a row");
        last.2[k] = r.number("t_b_s");
        last.3[k] = r.number("t_tr_s");
    }
    out
}

#[derive(Clone, Debug, Serialize)]
struct RtnewsRow {
    scene: String,
    structure: String,
    spec: String,
    published_build_s: f64,
    published_render_s: f64,
    /// Published render time over the uniform grid's at D = 1, and today's.
    published_over_d1: f64,
    build_ms: f64,
    render_ms: f64,
    measured_over_d1: f64,
    pit_per_ray: f64,
    vt_per_ray: f64,
}

fn rtnews_spd(o: &Options) -> Output {
    use crate::bench::{Candidate, Workload, bench_scene};
    let side = if o.quick { 65 } else { 513 };
    let mut report = format!(
        "# RTNews: hierarchical grids on the SPD scenes\n\nRegenerated by `hugrt reproduce \
         rtnews-spd{}`: the Whitted rendering of the SPD procedure at {side}×{side}, depth 4, \
         each structure by its hugrt spec, one timed run each on this machine (RTNews: a \
         350 MHz Pentium II). Compare ratios, not seconds: each render time is given over the \
         uniform grid's at D = 1 on the same scene.\n\n",
        if o.quick { " --quick" } else { "" }
    );
    let table = rtnews_table();
    let mut rows = Vec::new();
    let mut missing = Vec::new();
    for (k, name) in RTNEWS_SCENES.iter().enumerate() {
        let path = o.spd_dir.join(format!("{name}.nff.gz"));
        // Why a scene is skipped is part of the report: a file that is absent and a file
        // that does not parse (with its line) are different troubles.
        let scene = match crate::scene::Scene::open(&path.to_string_lossy()) {
            Ok(scene) => scene,
            Err(e) => {
                missing.push(e.to_string());
                continue;
            }
        };
        let candidates: Vec<Candidate> = table
            .iter()
            .map(|(_, spec, _, _)| Candidate::spec(&scene, spec))
            .collect();
        let workload = Workload::Whitted {
            width: Some(side),
            height: Some(side),
            depth: 4,
            soft_shadows: None,
        };
        let measured = match bench_scene(name, &scene, &candidates, workload, 1, &mut |_| {}) {
            Ok(m) => m,
            Err(e) => {
                missing.push(format!("{name}: {e}"));
                continue;
            }
        };
        let (pub_d1, ours_d1) = (table[0].3[k], measured[0].trace.median_ms);
        for ((label, spec, tb, ttr), m) in table.iter().zip(&measured) {
            rows.push(RtnewsRow {
                scene: name.to_string(),
                structure: label.to_string(),
                spec: spec.to_string(),
                published_build_s: tb[k],
                published_render_s: ttr[k],
                published_over_d1: ttr[k] / pub_d1,
                build_ms: m.build.median_ms,
                render_ms: m.trace.median_ms,
                measured_over_d1: m.trace.median_ms / ours_d1,
                pit_per_ray: m.per_ray[crate::accel::PIT],
                vt_per_ray: m.per_ray[crate::accel::VT],
            });
        }
    }
    if !missing.is_empty() {
        let _ = writeln!(
            report,
            "Skipped: {}. The SPD scenes ship in the project's shared folder; `--spd-dir` says \
             where.\n",
            missing.join("; ")
        );
    }
    let _ = writeln!(
        report,
        "| scene | structure | published T_TR / D=1 | today / D=1 | build ms | render ms | #pit | #vt |"
    );
    let _ = writeln!(report, "| --- | --- | --- | --- | --- | --- | --- | --- |");
    for r in &rows {
        let _ = writeln!(
            report,
            "| {} | {} (`{}`) | {:.2} | {:.2} | {:.1} | {:.1} | {:.2} | {:.2} |",
            r.scene,
            r.structure,
            r.spec,
            r.published_over_d1,
            r.measured_over_d1,
            r.build_ms,
            r.render_ms,
            r.pit_per_ray,
            r.vt_per_ray
        );
    }
    // The verdict: does the fastest structure of each scene stay the fastest?
    let mut same = 0;
    let mut scenes = 0;
    let mut lines = String::new();
    for name in RTNEWS_SCENES {
        let of: Vec<&RtnewsRow> = rows.iter().filter(|r| r.scene == name).collect();
        if of.is_empty() {
            continue;
        }
        scenes += 1;
        let best = |f: fn(&RtnewsRow) -> f64| {
            of.iter()
                .min_by(|a, b| f(a).total_cmp(&f(b)))
                .map(|r| r.structure.clone())
                .unwrap_or_default()
        };
        let (then, now) = (best(|r| r.published_render_s), best(|r| r.render_ms));
        same += (then == now) as usize;
        let _ = writeln!(lines, "- {name}: fastest then {then}, today {now}");
    }
    let _ = writeln!(
        report,
        "\nVerdict: the fastest structure of RTNews' table is still the fastest on {same} of \
         {scenes} scenes.\n\n{lines}\nOne run per structure on a shared machine: ratios within \
         ±20% are noise here.\n"
    );
    let mut csv = String::from(
        "scene,structure,spec,published_build_s,published_render_s,published_over_d1,build_ms,render_ms,measured_over_d1,pit_per_ray,vt_per_ray\n",
    );
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{}",
            r.scene,
            r.structure.replace(',', ";"),
            r.spec.replace(',', ";"),
            r.published_build_s,
            r.published_render_s,
            r.published_over_d1,
            r.build_ms,
            r.render_ms,
            r.measured_over_d1,
            r.pit_per_ray,
            r.vt_per_ray
        );
    }
    // Render time over the uniform grid's at D = 1, a curve per structure over the scenes,
    // then and now.
    let shown: Vec<&str> = RTNEWS_SCENES
        .iter()
        .copied()
        .filter(|n| rows.iter().any(|r| r.scene == *n))
        .collect();
    let curves = |published: bool| -> Vec<plot::Series> {
        table
            .iter()
            .map(|(label, _, _, _)| plot::Series {
                label: label.clone(),
                points: shown
                    .iter()
                    .enumerate()
                    .filter_map(|(k, n)| {
                        let r = rows
                            .iter()
                            .find(|r| r.scene == *n && r.structure == *label)?;
                        Some((
                            k as f64,
                            if published {
                                r.published_over_d1
                            } else {
                                r.measured_over_d1
                            },
                        ))
                    })
                    .collect(),
            })
            .collect()
    };
    let categories: Vec<String> = shown.iter().map(|s| s.to_string()).collect();
    let plots = vec![
        plot::Plot {
            stem: "render-over-d1-published",
            title: "RTNews: render time over the uniform grid's at D = 1 (1999)".to_string(),
            x_label: "SPD scene",
            y_label: "T_TR / D=1",
            series: curves(true),
            categories: categories.clone(),
        },
        plot::Plot {
            stem: "render-over-d1-today",
            title: "Render time over the uniform grid's at D = 1 (today)".to_string(),
            x_label: "SPD scene",
            y_label: "render / D=1",
            series: curves(false),
            categories,
        },
    ];
    let json = serde_json::to_string_pretty(&serde_json::json!({
        "target": "rtnews-spd",
        "image_side": side,
        "rows": rows,
        "skipped": missing,
    }))
    .expect("serialisable");
    Output {
        files: vec![
            ("report.md", report),
            ("rows.csv", csv),
            ("data.json", json + "\n"),
        ],
        plots,
    }
}
