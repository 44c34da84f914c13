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
mod rtnews;
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

impl Output {
    /// A target's files: `report.md`, its CSV tables by name, and `data.json` (pretty, with a
    /// final newline), with its plots.
    fn new(
        report: String,
        tables: Vec<(&'static str, String)>,
        data: serde_json::Value,
        plots: Vec<plot::Plot>,
    ) -> Output {
        let json = serde_json::to_string_pretty(&data).expect("serialisable") + "\n";
        let mut files = vec![("report.md", report)];
        files.extend(tables);
        files.push(("data.json", json));
        Output { files, plots }
    }
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
        run: rtnews::rtnews_spd,
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

/// `rows` as CSV, the header from the fields' names (the `csv` crate quotes a field that
/// holds a comma, such as a spec).
fn csv_of<T: Serialize>(rows: &[T]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r).expect("a flat row serialises");
    }
    String::from_utf8(w.into_inner().expect("in memory")).expect("UTF-8 fields")
}

/// The report's paragraph on the SPD scenes a target could not read, empty when none.
fn skipped_scenes(skipped: &[String]) -> String {
    if skipped.is_empty() {
        return String::new();
    }
    format!(
        "Skipped: {}. The SPD scenes ship in the project's shared folder; `--spd-dir` says \
         where.\n\n",
        skipped.join("; ")
    )
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
