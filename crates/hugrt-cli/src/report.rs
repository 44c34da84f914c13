//! Text reports of `hugrt stats` and `hugrt structures`: the scene's statistics (SCG97 Fig. 4) and the structure's,
//! with the per-level table of SCG97 §3 for grid hierarchies.

use hugrt::accel::{GridLevelStats, StructureStats};
use hugrt::stats::SceneStats;

/// What the per-level columns mean (SCG97 §3).
const LEVEL_LEGEND: &str =
    "  %obj, %grids, %voxels, %ptrs: the level's share of the objects (each counted once, where
  stored), grids, cells and references; %vol: its grids' volume over the top grid's (a sum far
  over 100 flags loose clusters, SCG97 7.1); μo_g: %obj / %grids, as SCG97's figure tables give
  it; raw μo_g: objects per grid; %o: cells holding objects; μo_v, σo_v: objects per cell, μo'_v,
  σo'_v: per cell holding any; max: the most in one cell; %g, μg_v, σg_v, μg'_v, σg'_v: the same
  for the grids a cell references.";

pub fn print_scene_stats(name: &str, s: &SceneStats, memory_bytes: usize) -> anyhow::Result<()> {
    say!("scene {name}");
    say!("  objects             {}", s.objects);
    say!("  scene diagonal      {:.6}", s.scene_diagonal);
    say!(
        "  min / max length    {:.3e} / {:.3e}",
        s.min_length,
        s.max_length
    );
    say!("  min/max             {:.3e}", s.min_over_max);
    say!("  min/diag            {:.3e}", s.min_over_diagonal);
    say!("  %.2                 {:.1}%", s.percent_below_0_2);
    say!("  length histogram (fraction of max length, 10 bins):");
    for (k, c) in s.histogram.iter().enumerate() {
        say!(
            "    [{:.1}, {:.1})  {c}",
            k as f32 / 10.0,
            (k + 1) as f32 / 10.0
        );
    }
    say!("  primitive memory    {memory_bytes} bytes");
    Ok(())
}

pub fn print_structure_stats(spec: &str, build_s: f64, st: &StructureStats) -> anyhow::Result<()> {
    say!("structure {spec} (built in {:.1} ms)", build_s * 1e3);
    for (k, v) in &st.entries {
        let v = if v.fract() == 0.0 {
            format!("{v}")
        } else {
            format!("{v:.4}")
        };
        say!("  {k:<31} {v}");
    }
    if st.levels.is_empty() {
        return Ok(());
    }
    if st.depths.is_empty() {
        say!(
            "per level (SCG97 3; level 0 is the top: the root grid, or an adaptive grid's clusters):"
        );
        print_levels(&st.levels)?;
    } else {
        say!("per filter level (SCG97 3; level 0 holds the largest objects, the world grid's):");
        print_levels(&st.levels)?;
        say!("per nesting depth (depth 0 is the world grid):");
        print_levels(&st.depths)?;
    }
    say!("{LEVEL_LEGEND}");
    Ok(())
}

fn print_levels(levels: &[GridLevelStats]) -> anyhow::Result<()> {
    say!(
        "  {:>5} {:>6} {:>9} {:>9} {:>9} {:>6} {:>6} {:>7} {:>6} {:>7} {:>10}",
        "level",
        "grids",
        "objects",
        "cells",
        "refs",
        "%obj",
        "%grids",
        "%voxels",
        "%ptrs",
        "%vol",
        "bytes"
    );
    for l in levels {
        say!(
            "  {:>5} {:>6} {:>9} {:>9} {:>9} {:>6.2} {:>6.2} {:>7.2} {:>6.2} {:>7.2} {:>10}",
            l.level,
            l.grids,
            l.objects,
            l.cells,
            l.object_refs + l.grid_refs,
            l.pct_obj,
            l.pct_grids,
            l.pct_voxels,
            l.pct_ptrs,
            l.pct_vol,
            l.memory_bytes
        );
    }
    say!(
        "  {:>5} {:>7} {:>8} {:>6} {:>7} {:>7} {:>7} {:>7} {:>6} {:>6} {:>7} {:>7} {:>7} {:>7}",
        "level",
        "μo_g",
        "raw μo_g",
        "%o",
        "μo_v",
        "σo_v",
        "μo'_v",
        "σo'_v",
        "max",
        "%g",
        "μg_v",
        "σg_v",
        "μg'_v",
        "σg'_v"
    );
    for l in levels {
        say!(
            "  {:>5} {:>7.2} {:>8.1} {:>6.2} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>6} {:>6.2} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
            l.level,
            l.mu_o_g,
            l.mu_o_g_raw,
            l.pct_o,
            l.mu_o_v,
            l.sigma_o_v,
            l.mu_o_v_nonempty,
            l.sigma_o_v_nonempty,
            l.max_o_v,
            l.pct_g,
            l.mu_g_v,
            l.sigma_g_v,
            l.mu_g_v_nonempty,
            l.sigma_g_v_nonempty
        );
    }
    Ok(())
}

/// `hugrt structures`: each structure, then a line per key (name, what it accepts, default)
/// with its help below.
pub fn print_structures(table: &[(&str, Vec<hugrt::accel::KeyHelp>)]) -> anyhow::Result<()> {
    for (k, (name, keys)) in table.iter().enumerate() {
        if k > 0 {
            say!();
        }
        if keys.is_empty() {
            say!("{name}: no keys");
            continue;
        }
        say!("{name}:KEY=VALUE,...");
        for key in keys {
            say!(
                "  {:<12} {}  (default {})",
                key.name,
                key.accepts,
                key.default
            );
            say!("               {}", key.help);
        }
    }
    Ok(())
}
