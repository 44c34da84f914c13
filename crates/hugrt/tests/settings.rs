//! Typed settings: every structure built without a spec string, the spec's keys read through
//! one table per structure, and the two agreeing.

mod common;

use common::*;
use hugrt::accel::hug::{ClusterRule, FilterRule};
use hugrt::accel::{
    Accel, AdaptiveSettings, AnyAccel, Bvh, BvhSettings, Grid, GridSettings, Hug, HugSettings,
    KdTree, KdTreeLayout, KdTreeSettings, Octree, OctreeSettings, Prune, RecursiveGrid,
    RecursiveGridSettings, STRUCTURES, Settings, Spec, StructureStats,
};
use hugrt::scene::Scene;

fn by_spec(scene: &Scene, spec: &str) -> StructureStats {
    AnyAccel::build(scene, spec)
        .unwrap_or_else(|e| panic!("{spec}: {e}"))
        .stats()
}

#[test]
fn typed_settings_build_what_their_spec_builds() {
    let scene = clustered_soup(5, 600);
    let typed: Vec<(&str, StructureStats)> = vec![
        (
            "grid:density=4,prune=true",
            Grid::with_settings(
                &scene,
                &GridSettings {
                    density: 4.0,
                    prune: Prune::All,
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
        (
            "bvh:leaf=2,spatial=0.5",
            Bvh::with_settings(
                &scene,
                &BvhSettings {
                    leaf: 2,
                    spatial: 0.5,
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
        (
            "kdtree:layout=compact,depth=12",
            KdTree::with_settings(
                &scene,
                &KdTreeSettings {
                    layout: KdTreeLayout::Compact,
                    depth: Some(12),
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
        (
            "octree:maxp=4",
            Octree::with_settings(
                &scene,
                &OctreeSettings {
                    maxp: 4,
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
        (
            "rgrid:maxp=8,hetero=false",
            RecursiveGrid::with_settings(
                &scene,
                &RecursiveGridSettings {
                    maxp: 8,
                    hetero: false,
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
        (
            "hug:filter=levels,cluster=cluster3d,crowd=off",
            Hug::with_settings(
                &scene,
                &HugSettings {
                    filter: FilterRule::Levels,
                    cluster: ClusterRule::Cluster3d,
                    crowd: None,
                    ..Default::default()
                },
            )
            .unwrap()
            .stats(),
        ),
    ];
    for (spec, stats) in typed {
        assert_eq!(stats.entries, by_spec(&scene, spec).entries, "{spec}");
    }
}

#[test]
fn typed_settings_out_of_range_are_errors_naming_the_key() {
    let scene = triangle_soup(1, 50);
    let cases = [
        (
            Bvh::with_settings(
                &scene,
                &BvhSettings {
                    leaf: 0,
                    ..Default::default()
                },
            )
            .err(),
            "leaf",
        ),
        (
            Grid::with_settings(
                &scene,
                &GridSettings {
                    density: f32::NAN,
                    ..Default::default()
                },
            )
            .err(),
            "density",
        ),
        (
            KdTree::with_settings(
                &scene,
                &KdTreeSettings {
                    depth: Some(1000),
                    ..Default::default()
                },
            )
            .err(),
            "depth",
        ),
        (
            hugrt::accel::AdaptiveGrid::with_settings(
                &scene,
                &AdaptiveSettings {
                    m: 2.0,
                    ..Default::default()
                },
            )
            .err(),
            "'m'",
        ),
    ];
    for (err, key) in cases {
        let e = err.expect(key).to_string();
        assert!(e.contains(key), "{key}: {e}");
    }
}

#[test]
fn every_spec_resolves_to_keys_that_build_the_same_structure() {
    let scene = clustered_soup(9, 400);
    for spec in specs() {
        let keys = AnyAccel::resolve(&spec).unwrap();
        let name = spec.split(':').next().unwrap();
        let full = format!(
            "{name}:{}",
            keys.iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(",")
        );
        assert_eq!(
            by_spec(&scene, &spec).entries,
            by_spec(&scene, &full).entries,
            "{spec} as {full}"
        );
    }
}

#[test]
fn every_key_is_described_with_its_default_and_what_it_accepts() {
    for name in STRUCTURES {
        let keys = AnyAccel::keys(name).unwrap();
        for k in &keys {
            assert!(!k.accepts.is_empty() && !k.default.is_empty() && !k.help.is_empty());
        }
        // The defaults written back are the structure with no keys.
        if !keys.is_empty() {
            let d: Vec<String> = keys
                .iter()
                .filter(|k| k.name != "preset")
                .map(|k| format!("{}={}", k.name, k.default))
                .collect();
            let scene = triangle_soup(2, 200);
            assert_eq!(
                by_spec(&scene, name).entries,
                by_spec(&scene, &format!("{name}:{}", d.join(","))).entries,
                "{name}"
            );
        }
    }
    let bvh = AnyAccel::keys("bvh").unwrap();
    assert_eq!(
        (
            bvh[0].name,
            bvh[0].accepts.as_str(),
            bvh[0].default.as_str()
        ),
        ("leaf", "1..16", "8")
    );
    let hug = AnyAccel::keys("hug").unwrap();
    assert_eq!(hug.last().unwrap().accepts, "eg95|scg97");
}

#[test]
fn settings_write_back_only_what_differs_from_the_defaults() {
    let s = HugSettings::from_spec(&Spec::parse("hug:preset=scg97,alpha=0.3").unwrap()).unwrap();
    let keys = s.to_spec_keys();
    assert!(
        keys.contains("alpha=0.3") && keys.contains("crowd=off"),
        "{keys}"
    );
    let again = HugSettings::from_spec(&Spec::parse(&format!("hug:{keys}")).unwrap()).unwrap();
    assert_eq!(again, s);
    assert_eq!(BvhSettings::default().to_spec_keys(), "");
}
