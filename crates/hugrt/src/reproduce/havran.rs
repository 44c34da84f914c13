//! `havran-splits`: Havran 1997 §4.2, Table 4 (how often the optimal splitting plane lies
//! outside the interval between the spatial and the object median) and Tables 5–6 (the
//! septet Δ and triplet Λ of the mid-point split against the SAH with empty space cut off).
//!
//! Choices where the paper is silent or differs: method (1) is `kdtree:split=mid` (Sung and
//! Shirley's mid-point split on cyclic axes, hugrt's leaf size and depth limit), method (2)
//! `kdtree:preset=havran`; Table 4's planes are method (2)'s. The object median of a node is
//! the first key position where the left side holds at least as many primitives as the right
//! (objects the plane cuts count on both sides), as in Havran's Fig. 9. The SPD scenes are
//! the real ones; Havran's fluid and m-fluid are not available and have no stand-in, and his
//! room is stood in for by hugrt's generated kitchen. The rendering is the SPD procedure
//! (Havran rendered his own images, size not given).

use super::Output;
use super::plot::{Plot, Series};
use super::published::Table;
use crate::bench::{BenchRow, Candidate, Workload, bench_scene};
use crate::scene::Scene;
use crate::scene::generate::generate;
use serde::Serialize;
use std::fmt::Write as _;

/// Havran's scenes and what stands in for each here: an SPD file, a generated scene, none.
enum Source {
    Spd(&'static str),
    Generated(&'static str, u32, u32),
    Missing,
}

const SCENES: &[(&str, Source)] = &[
    ("balls", Source::Spd("balls")),
    ("rings", Source::Spd("rings")),
    ("tetra", Source::Spd("tetra")),
    ("fluid", Source::Missing),
    ("m-fluid", Source::Missing),
    ("room", Source::Generated("kitchen", 2, 1)),
];

/// Methods (1) and (2) of Tables 5–6.
const METHODS: [(&str, &str); 2] = [
    ("(1) mid-point, cyclic axes", "kdtree:split=mid"),
    ("(2) SAH, empty space cut off", "kdtree:preset=havran"),
];

/// A ratio within this factor of 1 is a tie (one render per method at quick size, medians of
/// three at full size, on a shared machine).
const TIE: f64 = 1.10;

/// Table 4's claim: the optimal plane is "surprisingly" often outside the median interval;
/// here, more than one plane in ten.
const OFTEN: f64 = 10.0;

/// The properties of Tables 5–6 in the data file's names, their labels, and today's value.
/// A property's value in a bench row, where it has one.
type Measure = fn(&BenchRow) -> Option<f64>;

const PROPERTIES: &[(&str, &str, Measure)] = &[
    ("n_c", "N_C", |r| Some(r.septet.n_c as f64)),
    ("r_etnc_percent", "R_ETNC [%]", |r| {
        Some(100.0 * r.septet.r_etnc)
    }),
    ("n_adc_percent", "N_ADC [%]", |r| {
        Some(100.0 * r.septet.n_adc)
    }),
    ("n_aoifc", "N_AOIFC", |r| Some(r.septet.n_aoifc)),
    ("r_fvwv_percent", "R_FVWV [%]", |r| {
        Some(100.0 * r.septet.r_fvwv)
    }),
    ("n_rprt", "N_RPRT", |r| Some(r.septet.n_rprt)),
    ("n_at", "N_AT", |r| Some(r.septet.n_at)),
    ("t_cb_s", "T_CB", |r| Some(r.triplet.t_cb_ms / 1e3)),
    ("t_tr_s", "T_TR", |r| Some(r.triplet.t_tr_ms / 1e3)),
    ("t_tt_over_t_tr_percent", "T_TT/T_TR [%]", |r| {
        r.triplet.t_tt_over_t_tr.map(|x| 100.0 * x)
    }),
];

#[derive(Clone, Debug, Serialize)]
struct PlaneRow {
    scene: &'static str,
    stand_in: String,
    published_planes: f64,
    published_outside_percent: f64,
    planes: f64,
    outside_percent: f64,
}

#[derive(Clone, Debug, Serialize)]
struct PropertyRow {
    scene: &'static str,
    stand_in: String,
    property: &'static str,
    published_1: f64,
    published_2: f64,
    measured_1: Option<f64>,
    measured_2: Option<f64>,
}

impl PropertyRow {
    fn published_ratio(&self) -> f64 {
        self.published_2 / self.published_1
    }
    fn measured_ratio(&self) -> Option<f64> {
        Some(self.measured_2? / self.measured_1?).filter(|r| r.is_finite())
    }
}

pub(super) fn havran_splits(o: &super::Options) -> Output {
    let table4 = Table::load("havran97-table4.csv");
    let tables56 = Table::load("havran97-tables5-6.csv");
    let (side, repeat) = if o.quick { (33, 1) } else { (257, 3) };
    let workload = Workload::Whitted {
        width: Some(side),
        height: Some(side),
        depth: 4,
        soft_shadows: None,
    };
    let mut planes = Vec::new();
    let mut properties = Vec::new();
    let mut skipped = Vec::new();
    for (name, source) in SCENES {
        let (scene, stand_in) = match source {
            Source::Missing => {
                skipped.push(format!("{name}: not available, no stand-in"));
                continue;
            }
            Source::Spd(file) => {
                let path = o.spd_dir.join(format!("{file}.nff.gz"));
                match Scene::open(&path.to_string_lossy()) {
                    Ok(s) => (s, format!("SPD {file}")),
                    Err(e) => {
                        skipped.push(e.to_string());
                        continue;
                    }
                }
            }
            Source::Generated(kind, size, quick_size) => {
                let size = if o.quick { *quick_size } else { *size };
                let scene = generate(kind, size, 1).expect("a generated kind");
                (scene, format!("builtin:{kind}:{size}"))
            }
        };
        let stats = match crate::accel::AnyAccel::build(&scene, METHODS[1].1) {
            Ok(tree) => tree.stats(),
            Err(e) => {
                skipped.push(format!("{name}: {e}"));
                continue;
            }
        };
        let stat = |key: &str| {
            stats
                .entries
                .iter()
                .find(|(k, _)| k == key)
                .map_or(0.0, |e| e.1)
        };
        let published = table4.rows_where("scene", name).next().expect("a row");
        planes.push(PlaneRow {
            scene: name,
            stand_in: stand_in.clone(),
            published_planes: published.number("planes"),
            published_outside_percent: published.number("outside_percent"),
            planes: stat("sah_planes"),
            outside_percent: 100.0 * stat("planes_outside_median") / stat("sah_planes").max(1.0),
        });
        let candidates: Vec<Candidate> = METHODS
            .iter()
            .map(|(_, spec)| Candidate::alone(&scene, spec))
            .collect();
        let measured = match bench_scene(name, &scene, &candidates, workload, repeat, &mut |_| {}) {
            Ok(m) => m,
            Err(e) => {
                skipped.push(format!("{name}: {e}"));
                continue;
            }
        };
        for (key, _, value) in PROPERTIES {
            let p = tables56
                .rows_where("scene", name)
                .find(|r| r.text("property") == *key)
                .expect("a published property");
            properties.push(PropertyRow {
                scene: name,
                stand_in: stand_in.clone(),
                property: key,
                published_1: p.number("method1"),
                published_2: p.number("method2"),
                measured_1: value(&measured[0]),
                measured_2: value(&measured[1]),
            });
        }
    }
    let mut report = format!(
        "# Havran 1997 §4.2: where the optimal plane lies, and what the SAH gains\n\n\
         Regenerated by `hugrt reproduce havran-splits{}`. Method (1) is `{}`, method (2) \
         `{}`; Table 4 counts method (2)'s planes. Renderings: the SPD procedure at \
         {side}×{side}, depth 4, the median of {repeat} run(s) on this machine (Havran: a \
         workstation of 1997). Published figures: `data/published/{}` and `{}`.\n\n",
        if o.quick { " --quick" } else { "" },
        METHODS[0].1,
        METHODS[1].1,
        table4.file,
        tables56.file,
    );
    report.push_str(&super::skipped_scenes(&skipped));
    let _ = writeln!(
        report,
        "## Table 4: planes outside the median interval\n\n| scene | stand-in | planes \
         (published) | outside % (published) | planes | outside % |\n| --- | --- | --- | --- \
         | --- | --- |"
    );
    for p in &planes {
        let _ = writeln!(
            report,
            "| {} | {} | {} | {:.1} | {} | {:.1} |",
            p.scene,
            p.stand_in,
            p.published_planes,
            p.published_outside_percent,
            p.planes,
            p.outside_percent
        );
    }
    let _ = writeln!(
        report,
        "\n## Tables 5–6: Δ and Λ, method (2) over method (1)\n\nTimes are compared as ratios \
         (2)/(1) only; counts and percentages also as values.\n\n| scene | property | (1) \
         published | (2) published | (2)/(1) published | (1) | (2) | (2)/(1) |\n| --- | --- \
         | --- | --- | --- | --- | --- | --- |"
    );
    let show = |x: Option<f64>| x.map_or("–".to_string(), significant);
    for p in &properties {
        let _ = writeln!(
            report,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            p.scene,
            PROPERTIES
                .iter()
                .find(|q| q.0 == p.property)
                .map_or(p.property, |q| q.1),
            p.published_1,
            p.published_2,
            significant(p.published_ratio()),
            show(p.measured_1),
            show(p.measured_2),
            show(p.measured_ratio())
        );
    }
    report.push_str(&verdicts(&planes, &properties));
    let mut csv = String::from(
        "scene,stand_in,property,published_1,published_2,published_ratio,measured_1,measured_2,measured_ratio\n",
    );
    let opt = |x: Option<f64>| x.map_or(String::new(), |x| x.to_string());
    for p in &properties {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{}",
            p.scene,
            p.stand_in,
            p.property,
            p.published_1,
            p.published_2,
            p.published_ratio(),
            opt(p.measured_1),
            opt(p.measured_2),
            opt(p.measured_ratio())
        );
    }
    let planes_csv = super::csv_of(&planes);
    let scenes: Vec<String> = planes.iter().map(|p| p.scene.to_string()).collect();
    let indexed = |f: &dyn Fn(&PlaneRow) -> f64| -> Vec<(f64, f64)> {
        planes
            .iter()
            .enumerate()
            .map(|(k, p)| (k as f64, f(p)))
            .collect()
    };
    let ratio_of = |key: &str, published: bool| -> Vec<(f64, f64)> {
        planes
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                let row = properties
                    .iter()
                    .find(|q| q.scene == p.scene && q.property == key)?;
                let r = if published {
                    row.published_ratio()
                } else {
                    row.measured_ratio()?
                };
                Some((k as f64, r))
            })
            .collect()
    };
    let plots = vec![
        Plot {
            stem: "table4-outside-median",
            title: "Havran Table 4: SAH planes outside the median interval".to_string(),
            x_label: "scene",
            y_label: "% of planes",
            series: vec![
                Series {
                    label: "Havran 1997".into(),
                    points: indexed(&|p| p.published_outside_percent),
                },
                Series {
                    label: "today".into(),
                    points: indexed(&|p| p.outside_percent),
                },
            ],
            categories: scenes.clone(),
        },
        Plot {
            stem: "tables5-6-render-ratio",
            title: "Havran Tables 5-6: render time of SAH with cutting over mid-point".to_string(),
            x_label: "scene",
            y_label: "T_TR (2) / (1)",
            series: vec![
                Series {
                    label: "Havran 1997".into(),
                    points: ratio_of("t_tr_s", true),
                },
                Series {
                    label: "today".into(),
                    points: ratio_of("t_tr_s", false),
                },
            ],
            categories: scenes,
        },
    ];
    Output::new(
        report,
        vec![("planes.csv", planes_csv), ("properties.csv", csv)],
        serde_json::json!({
            "target": "havran-splits",
            "image_side": side,
            "methods": METHODS.iter().map(|m| m.1).collect::<Vec<_>>(),
            "planes": planes,
            "properties": properties,
            "skipped": skipped,
        }),
        plots,
    )
}

/// The verdicts, computed from the rows: Table 4's "often outside", and for Tables 5–6 that
/// method (2) renders faster, traverses fewer cells and tests fewer primitives per hit.
fn verdicts(planes: &[PlaneRow], properties: &[PropertyRow]) -> String {
    let mut out = format!(
        "\n## Verdict\n\nThresholds: a plane is \"often\" outside the median interval above \
         {OFTEN}% of the planes; a ratio (2)/(1) is a gain below 1/{TIE} and a tie within \
         ×{TIE}.\n\n"
    );
    let often = planes.iter().filter(|p| p.outside_percent > OFTEN).count();
    let listed: Vec<String> = planes
        .iter()
        .map(|p| {
            format!(
                "{} {:.1}% (published {:.1}%)",
                p.scene, p.outside_percent, p.published_outside_percent
            )
        })
        .collect();
    if !planes.is_empty() {
        let _ = writeln!(
            out,
            "- Table 4, \"the number of splitting planes outside the median interval is \
             surprisingly high\": {} here, on {often} of {} scenes ({}), so MacDonald and \
             Booth's interval would miss the best plane that often.",
            if often == planes.len() {
                "holds"
            } else if often > 0 {
                "holds in part"
            } else {
                "does not hold"
            },
            planes.len(),
            listed.join(", ")
        );
    }
    for (key, claim) in [
        ("t_tr_s", "method (2) renders faster than method (1)"),
        ("n_at", "method (2) traverses fewer cells per ray"),
        ("n_rprt", "method (2) tests fewer primitives per hit"),
    ] {
        let of: Vec<&PropertyRow> = properties.iter().filter(|p| p.property == key).collect();
        if of.is_empty() {
            continue;
        }
        let gains = of
            .iter()
            .filter(|p| p.measured_ratio().is_some_and(|r| r < 1.0 / TIE))
            .count();
        let ties = of
            .iter()
            .filter(|p| {
                p.measured_ratio()
                    .is_some_and(|r| (1.0 / TIE..=TIE).contains(&r))
            })
            .count();
        let published_gains = of
            .iter()
            .filter(|p| p.published_ratio() < 1.0 / TIE)
            .count();
        let pairs: Vec<String> = of
            .iter()
            .map(|p| {
                format!(
                    "{} {} (published {:.2})",
                    p.scene,
                    p.measured_ratio().map_or("–".into(), |r| format!("{r:.2}")),
                    p.published_ratio()
                )
            })
            .collect();
        let _ = writeln!(
            out,
            "- Tables 5–6, {claim}: {} here, a gain on {gains} of {} scenes and a tie on \
             {ties} (published: a gain on {published_gains}); ratios (2)/(1): {}.",
            if gains == of.len() {
                "holds"
            } else if gains + ties == of.len() {
                "holds or ties"
            } else if gains > 0 {
                "holds in part"
            } else {
                "does not hold"
            },
            of.len(),
            pairs.join(", ")
        );
    }
    // hugrt's kd-tree allows 63 references per primitive beyond the first (its reference
    // budget); a method that spends it stops splitting where it stands.
    let starved: Vec<String> = properties
        .iter()
        .filter(|p| p.property == "n_adc_percent")
        .filter(|p| p.measured_1.is_some_and(|x| x > 0.95 * 6300.0))
        .map(|p| {
            let tests = properties
                .iter()
                .find(|q| q.scene == p.scene && q.property == "n_rprt")
                .and_then(|q| q.measured_1);
            format!(
                "{} (N_ADC {:.0}%, N_RPRT {})",
                p.scene,
                p.measured_1.unwrap_or(0.0),
                tests.map_or("–".into(), significant)
            )
        })
        .collect();
    if !starved.is_empty() {
        let _ = writeln!(
            out,
            "- Why the widest gaps: method (1) spent hugrt's reference budget (63 extra \
             references per primitive) on {}, so its leaves there stay crowded.",
            starved.join(", ")
        );
    }
    out
}

/// `x` with four significant digits, without an exponent for everyday magnitudes.
pub(super) fn significant(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{x:.digits$}")
}

/// hugrt's layouts in Havran's Table 7 order, with breadth-first beside them.
const LAYOUTS: [&str; 5] = [
    "scattered",
    "depth-first",
    "breadth-first",
    "subtrees",
    "compact",
];

/// Havran's simulated cache (§4.3.5): 1 MB, four-way set-associative, 128-byte lines, given
/// to cachegrind as its first-level data cache (and a larger last level, which it requires).
const HAVRAN_CACHE: [&str; 2] = ["--D1=1048576,4,128", "--LL=8388608,16,128"];

#[derive(Clone, Debug, Serialize)]
struct LayoutRow {
    layout: &'static str,
    spec: String,
    trace_ms: f64,
    mrays_per_s: f64,
    memory_bytes: usize,
    /// Over depth-first's trace time.
    time_over_dfs: f64,
    /// From cachegrind with Havran's cache, per ray of the difference of two ray counts.
    data_refs_per_ray: Option<f64>,
    d1_misses_per_ray: Option<f64>,
    d1_hit_percent: Option<f64>,
}

/// Data references and first-level data misses of one run under cachegrind, or why not.
fn cachegrind(exe: &std::path::Path, args: &[String]) -> Result<(f64, f64), String> {
    let out = std::process::Command::new("valgrind")
        .args([
            "--tool=cachegrind",
            "--cache-sim=yes",
            "--cachegrind-out-file=/dev/null",
        ])
        .args(HAVRAN_CACHE)
        .arg(exe)
        .args(args)
        .output()
        .map_err(|e| format!("valgrind: {e}"))?;
    let text = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!(
            "valgrind exited with {}: {}",
            out.status,
            text.lines().last().unwrap_or("")
        ));
    }
    let read = |label: &str| {
        text.lines()
            .find_map(|l| {
                let rest = l.split_once(label)?.1;
                let n: String = rest
                    .trim_start()
                    .chars()
                    .take_while(|c| c.is_ascii_digit() || *c == ',')
                    .filter(|c| *c != ',')
                    .collect();
                n.parse::<f64>().ok()
            })
            .ok_or_else(|| format!("no '{label}' in cachegrind's summary"))
    };
    Ok((read("D   refs:")?, read("D1  misses:")?))
}

/// `havran-layouts`: Havran 1997 §4.3, Tables 7–8: the kd-tree's layouts in memory, their
/// trace time and their cache behaviour (cachegrind with Havran's simulated cache).
///
/// Choices: the tree is `kdtree:preset=havran` with each `layout` on the generated kitchen
/// (its tree of about 6 MB is several times Havran's 1 MB cache; a building of four kitchens
/// took 11 minutes under cachegrind for the same verdicts); the rays are incoherent
/// (origins in the box, directions on the sphere), so that paths through the tree differ
/// from ray to ray as Havran's depth-first traversals of the whole tree do. Cachegrind
/// counts every data access of the process, not the nodes' alone: the accesses of the
/// tracing are isolated as the difference between runs of 2N and N rays, and their hit
/// ratio stands beside Havran's per-node C_HR. Table 8's ratio by depth needs each node
/// access tagged with its depth, which cachegrind cannot do; it is not regenerated.
pub(super) fn havran_layouts(o: &super::Options) -> Output {
    let table7 = Table::load("havran97-table7.csv");
    let (kind, size, rays, repeat, cg_rays) = if o.quick {
        ("room", 3000, 20_000, 1, 1_000)
    } else {
        ("kitchen", 2, 1_000_000, 5, 20_000)
    };
    let name = format!("builtin:{kind}:{size}");
    // The room is `Scene::open`'s built-in, not a generated kind.
    let scene = if kind == "room" {
        Scene::open(&name).expect("a built-in scene")
    } else {
        generate(kind, size, 1).expect("a generated kind")
    };
    let specs: Vec<String> = LAYOUTS
        .iter()
        .map(|l| format!("kdtree:preset=havran,layout={l}"))
        .collect();
    let candidates: Vec<Candidate> = specs.iter().map(|s| Candidate::alone(&scene, s)).collect();
    let mut problems = Vec::new();
    let measured = bench_scene(
        &name,
        &scene,
        &candidates,
        Workload::Incoherent { rays },
        repeat,
        &mut |_| {},
    )
    .unwrap_or_else(|e| {
        problems.push(format!("{name}: {e}"));
        Vec::new()
    });
    let dfs = measured
        .get(1)
        .map_or(f64::NAN, |m: &BenchRow| m.trace.median_ms);
    let mut rows: Vec<LayoutRow> = LAYOUTS
        .iter()
        .zip(&specs)
        .zip(&measured)
        .map(|((layout, spec), m)| LayoutRow {
            layout,
            spec: spec.clone(),
            trace_ms: m.trace.median_ms,
            mrays_per_s: m.mrays_per_s,
            memory_bytes: m.memory_bytes,
            time_over_dfs: m.trace.median_ms / dfs,
            data_refs_per_ray: None,
            d1_misses_per_ray: None,
            d1_hit_percent: None,
        })
        .collect();
    // Cachegrind, where it and the hugrt binary are at hand.
    let valgrind = std::process::Command::new("valgrind")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    let cache_note = match (&o.hugrt_exe, valgrind) {
        (None, _) => "Cachegrind was not run: no hugrt binary to run under it (the library's \
                      caller gave none; `hugrt reproduce` gives itself)."
            .to_string(),
        (Some(_), false) => "Cachegrind was not run: valgrind is not installed here \
                             (Debian's package `valgrind`)."
            .to_string(),
        (Some(exe), true) => {
            for row in rows.iter_mut() {
                let args = |n: usize| -> Vec<String> {
                    [
                        "bench",
                        &name,
                        "--accel",
                        &row.spec,
                        "--rays",
                        "incoherent",
                        "--ray-count",
                        &n.to_string(),
                        "--repeat",
                        "1",
                        "--threads",
                        "1",
                    ]
                    .iter()
                    .map(|s| s.to_string())
                    .collect()
                };
                match (
                    cachegrind(exe, &args(cg_rays)),
                    cachegrind(exe, &args(2 * cg_rays)),
                ) {
                    (Ok((r1, m1)), Ok((r2, m2))) => {
                        // Where the tree fits in the cache, the misses of the two runs
                        // differ by the process's noise alone, either way: below zero is none.
                        let (refs, misses) = (r2 - r1, (m2 - m1).max(0.0));
                        row.data_refs_per_ray = Some(refs / cg_rays as f64);
                        row.d1_misses_per_ray = Some(misses / cg_rays as f64);
                        row.d1_hit_percent =
                            Some(100.0 * (1.0 - misses / refs.max(1.0))).filter(|x| x.is_finite());
                    }
                    (Err(e), _) | (_, Err(e)) => problems.push(format!("{}: {e}", row.layout)),
                }
            }
            format!(
                "Cachegrind ran `hugrt bench {name} --rays incoherent` with {cg_rays} and {} \
                 rays per layout, one thread, with Havran's cache ({}); the columns are the \
                 difference per ray.",
                2 * cg_rays,
                HAVRAN_CACHE.join(" ")
            )
        }
    };
    let mut report = format!(
        "# Havran 1997 §4.3: the kd-tree's layouts in memory\n\nRegenerated by `hugrt \
         reproduce havran-layouts{}` on `{name}` ({} primitives): `kdtree:preset=havran` with \
         each layout, {rays} incoherent rays, the median of {repeat} run(s) on this machine. \
         Havran's times are cycles of a model and of a simulation (a 1 MB cache, T_MM = 53 \
         cycles): compare ratios to depth-first. {cache_note} Published figures: \
         `data/published/{}` and `havran97-table8.csv`.\n\n",
        if o.quick { " --quick" } else { "" },
        scene.len(),
        table7.file
    );
    if !problems.is_empty() {
        let _ = writeln!(report, "Problems: {}.\n", problems.join("; "));
    }
    let _ = writeln!(
        report,
        "| layout | Havran's representation | t'_A / DFS published | C_HR % published | trace ms \
         | Mrays/s | time / depth-first | MB | data refs per ray | D1 misses per ray | D1 hits % \
         |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    let dfs_published = table7
        .rows_where("layout", "depth-first")
        .next()
        .map_or(f64::NAN, |r| r.number("t_a_simulated"));
    let opt = |x: Option<f64>| x.map_or("–".into(), significant);
    for r in &rows {
        let p = table7.rows_where("layout", r.layout).next();
        let _ = writeln!(
            report,
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} | {} | {} | {} |",
            r.layout,
            p.map_or("–", |p| p.text("representation")),
            p.map_or("–".into(), |p| significant(
                p.number("t_a_simulated") / dfs_published
            )),
            p.map_or("–", |p| p.text("c_hr_percent")),
            significant(r.trace_ms),
            significant(r.mrays_per_s),
            significant(r.time_over_dfs),
            r.memory_bytes as f64 / 1e6,
            opt(r.data_refs_per_ray),
            opt(r.d1_misses_per_ray),
            opt(r.d1_hit_percent)
        );
    }
    report.push_str(&layout_verdicts(&rows));
    let csv = super::csv_of(&rows);
    let names: Vec<String> = rows.iter().map(|r| r.layout.to_string()).collect();
    let published_points: Vec<(f64, f64)> = rows
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let p = table7.rows_where("layout", r.layout).next()?;
            Some((k as f64, p.number("t_a_simulated") / dfs_published))
        })
        .collect();
    let mut plots = vec![Plot {
        stem: "table7-time",
        title: "Havran Table 7: traversal time over depth-first's, by layout".to_string(),
        x_label: "layout",
        y_label: "time / depth-first",
        series: vec![
            Series {
                label: "Havran 1997 (simulated t'_A)".into(),
                points: published_points,
            },
            Series {
                label: "today".into(),
                points: rows
                    .iter()
                    .enumerate()
                    .map(|(k, r)| (k as f64, r.time_over_dfs))
                    .collect(),
            },
        ],
        categories: names.clone(),
    }];
    let misses: Vec<(f64, f64)> = rows
        .iter()
        .enumerate()
        .filter_map(|(k, r)| Some((k as f64, r.d1_misses_per_ray?)))
        .collect();
    if !misses.is_empty() {
        plots.push(Plot {
            stem: "table7-misses",
            title: "First-level data misses per ray with Havran's cache (cachegrind)".to_string(),
            x_label: "layout",
            y_label: "D1 misses per ray",
            series: vec![Series {
                label: "today".into(),
                points: misses,
            }],
            categories: names,
        });
    }
    Output::new(
        report,
        vec![("layouts.csv", csv)],
        serde_json::json!({
            "target": "havran-layouts",
            "scene": name,
            "rays": rays,
            "rows": rows,
            "cachegrind": cache_note,
            "problems": problems,
        }),
        plots,
    )
}

fn layout_verdicts(rows: &[LayoutRow]) -> String {
    let mut out = format!(
        "\n## Verdict\n\nThresholds: a ratio of times is a gain below 1/{TIE} and a tie within \
         ×{TIE}; misses are ordered when each layout's are at most ×{TIE} the previous \
         one's.\n\n"
    );
    let of = |l: &str| rows.iter().find(|r| r.layout == l);
    let judge = |r: f64, claim_faster: bool| {
        let faster = if claim_faster { r < 1.0 / TIE } else { r > TIE };
        if faster {
            "holds"
        } else if (1.0 / TIE..=TIE).contains(&r) {
            "is a tie here"
        } else {
            "does not hold"
        }
    };
    for (layout, published) in [("subtrees", 0.708), ("compact", 0.603)] {
        if let Some(r) = of(layout) {
            let _ = writeln!(
                out,
                "- Table 7, the {layout} representation traverses faster than depth-first: {} \
                 (time over depth-first {:.2}; published t'_A {published:.2}).",
                judge(r.time_over_dfs, true),
                r.time_over_dfs
            );
        }
    }
    if let Some(r) = of("scattered") {
        let _ = writeln!(
            out,
            "- Table 7, nodes at random are the slowest: slower than depth-first {} (time over \
             depth-first {:.2}; published t'_A 1.57).",
            judge(r.time_over_dfs, false),
            r.time_over_dfs
        );
    }
    if let (Some(c), Some(d)) = (of("compact"), of("depth-first")) {
        let ratio = c.memory_bytes as f64 / d.memory_bytes.max(1) as f64;
        let _ = writeln!(
            out,
            "- §4.3.5, \"the memory required for representation of the binary tree is \
             decreased by 57%\": {} here (compact over depth-first, the whole structure with \
             its references: {ratio:.2}; published 0.43).",
            if ratio < 1.0 / TIE {
                "holds"
            } else {
                "does not hold"
            }
        );
    }
    let order = ["scattered", "depth-first", "subtrees", "compact"];
    let misses: Vec<(String, f64)> = order
        .iter()
        .filter_map(|l| Some((l.to_string(), of(l)?.d1_misses_per_ray?)))
        .collect();
    if misses.len() == order.len() {
        let ordered = misses.windows(2).all(|w| w[1].1 <= w[0].1 * TIE);
        let listed: Vec<String> = misses
            .iter()
            .map(|(l, m)| format!("{l} {}", significant(*m)))
            .collect();
        let _ = writeln!(
            out,
            "- Table 7, the hit ratio rises from random through depth-first and subtrees to \
             compact (published 35.8, 69.8, 83.5, 90.3%), so misses fall in that order: {} \
             here (first-level data misses per ray: {}); the hit ratio of all data accesses \
             is in the table, nodes' and everything else's together.",
            if ordered { "holds" } else { "does not hold" },
            listed.join(", ")
        );
    } else {
        out.push_str(
            "- Table 7's hit ratios: not judged, cachegrind's figures are missing (see above).\n",
        );
    }
    out
}
