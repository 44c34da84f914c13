//! Text reports of `hugrt stats`: the scene's statistics (SCG97 Fig. 4) and the structure's,
//! with the per-level table of SCG97 §3 for grid hierarchies.

use hugrt::accel::StructureStats;
use hugrt::stats::SceneStats;

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
    say!("per level (SCG97 3; level 0 is the top: the root grid, or an adaptive grid's clusters):");
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
    for l in &st.levels {
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
        "  {:>5} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7} {:>6} {:>7} {:>7} {:>7} {:>7}",
        "level",
        "μo_g",
        "%o",
        "μo_v",
        "σo_v",
        "μo'_v",
        "σo'_v",
        "%g",
        "μg_v",
        "σg_v",
        "μg'_v",
        "σg'_v"
    );
    for l in &st.levels {
        say!(
            "  {:>5} {:>7.2} {:>6.2} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>6.2} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
            l.level,
            l.mu_o_g,
            l.pct_o,
            l.mu_o_v,
            l.sigma_o_v,
            l.mu_o_v_nonempty,
            l.sigma_o_v_nonempty,
            l.pct_g,
            l.mu_g_v,
            l.sigma_g_v,
            l.mu_g_v_nonempty,
            l.sigma_g_v_nonempty
        );
    }
    Ok(())
}
