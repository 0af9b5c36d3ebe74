//! Round trip of an Exodus results file through our writer and reader.
//!
//! With `PERIDYN_KEEP_FIXTURES=<dir>` the file is also written to `<dir>/roundtrip.e`, with
//! `<dir>/roundtrip.json` describing exactly what was written, so that
//! `scripts/check_exodus.py <dir>` can verify it with netCDF4 and meshio independently.

use std::path::Path;

use peridyn::io::exodus::{ExodusFile, ExodusWriter, OutputBlock, OutputLayout, OutputNodeSet};
use serde_json::{json, Value};

const FRAMES: usize = 3;

/// 2 blocks, 2 node sets, vector nodal fields (as Peridigm writes them), scalar element
/// fields and global variables on a 3 × 2 × 2 grid of points.
fn layout() -> OutputLayout {
    let mut coordinates = Vec::new();
    for k in 0..2 {
        for j in 0..2 {
            for i in 0..3 {
                coordinates.push([0.5 * i as f64, 0.25 + 0.5 * j as f64, -1.0 + 0.5 * k as f64]);
            }
        }
    }
    let n = coordinates.len() as u32;
    OutputLayout {
        title: "peridyn exodus round trip".to_string(),
        node_ids: (1..=n as i64).collect(),
        coordinates,
        // Interleaved membership so that block order differs from node order.
        blocks: vec![
            OutputBlock {
                id: 1,
                name: "block_1".to_string(),
                nodes: (0..n).filter(|k| k % 3 != 2).collect(),
                undefined: Vec::new(),
            },
            OutputBlock {
                id: 2,
                name: "block_2".to_string(),
                nodes: (0..n).filter(|k| k % 3 == 2).collect(),
                undefined: Vec::new(),
            },
        ],
        node_sets: vec![
            OutputNodeSet {
                id: 1,
                name: "Min_X_Node_Set".to_string(),
                nodes: (0..n).filter(|k| k % 3 == 0).collect(),
            },
            OutputNodeSet {
                id: 2,
                name: "Max_Z_Node_Set".to_string(),
                nodes: (6..n).collect(),
            },
        ],
        nodal_variables: ["DisplacementX", "DisplacementY", "DisplacementZ"]
            .map(String::from)
            .to_vec(),
        element_variables: ["Damage", "Dilatation"].map(String::from).to_vec(),
        global_variables: ["Kinetic_Energy", "Strain_Energy"]
            .map(String::from)
            .to_vec(),
    }
}

/// Frame `f`, variable `v`, node `n`: distinct, non-round values.
fn nodal(f: usize, v: usize, n: usize) -> f64 {
    1e-3 * (f as f64 + 1.0) * (n as f64 + 1.0) / (v as f64 + 3.0)
}

fn element(f: usize, v: usize, n: usize) -> f64 {
    (f as f64 * 0.1 + n as f64 * 0.01 + v as f64) / 7.0
}

fn global(f: usize, v: usize) -> f64 {
    (f as f64 + 0.5).powi(2) * if v == 0 { 1.0 / 3.0 } else { 2.0 / 3.0 }
}

fn time(f: usize) -> f64 {
    f as f64 * 1.5e-6
}

fn write(path: &Path, layout: &OutputLayout) {
    let n = layout.coordinates.len();
    let mut writer = ExodusWriter::create(path, layout).unwrap();
    for f in 0..FRAMES {
        let nodal_fields: Vec<Vec<f64>> = (0..3)
            .map(|v| (0..n).map(|k| nodal(f, v, k)).collect())
            .collect();
        let element_fields: Vec<Vec<f64>> = (0..2)
            .map(|v| (0..n).map(|k| element(f, v, k)).collect())
            .collect();
        let globals: Vec<f64> = (0..2).map(|v| global(f, v)).collect();
        let nodal_refs: Vec<&[f64]> = nodal_fields.iter().map(Vec::as_slice).collect();
        let element_refs: Vec<&[f64]> = element_fields.iter().map(Vec::as_slice).collect();
        writer
            .write_frame(time(f), &nodal_refs, &element_refs, &globals)
            .unwrap();
    }
    assert_eq!(writer.frames_written(), FRAMES);
    writer.finish().unwrap();
}

fn check(path: &Path, layout: &OutputLayout) {
    let file = ExodusFile::open(path).unwrap();
    assert_eq!(file.title, layout.title);
    assert_eq!(file.coordinates, layout.coordinates);
    assert_eq!(file.node_ids, layout.node_ids);
    assert_eq!(file.blocks.len(), 2);
    for (read, written) in file.blocks.iter().zip(&layout.blocks) {
        assert_eq!(
            (read.id, &read.name, &read.connectivity),
            (written.id, &written.name, &written.nodes)
        );
        assert_eq!(read.element_type, "SPHERE");
    }
    for (read, written) in file.node_sets.iter().zip(&layout.node_sets) {
        assert_eq!(
            (read.id, &read.name, &read.nodes),
            (written.id, &written.name, &written.nodes)
        );
    }
    assert_eq!(file.nodal_variable_names, layout.nodal_variables);
    assert_eq!(file.element_variable_names, layout.element_variables);
    assert_eq!(file.global_variable_names, layout.global_variables);
    assert_eq!(file.times, (0..FRAMES).map(time).collect::<Vec<_>>());
    let n = layout.coordinates.len();
    for f in 0..FRAMES {
        for v in 0..3 {
            let expected: Vec<f64> = (0..n).map(|k| nodal(f, v, k)).collect();
            assert_eq!(file.nodal_values(f, v).unwrap(), expected);
        }
        for (b, block) in layout.blocks.iter().enumerate() {
            for v in 0..2 {
                let expected: Vec<f64> = block
                    .nodes
                    .iter()
                    .map(|&k| element(f, v, k as usize))
                    .collect();
                assert_eq!(file.element_values(f, v, b).unwrap(), Some(expected));
            }
        }
        assert_eq!(
            file.global_values(f).unwrap(),
            vec![global(f, 0), global(f, 1)]
        );
    }
}

/// JSON description of what [`write`] put in the file (node-set members 1-based, as in
/// Exodus), plus sample values for the independent checker.
fn describe(layout: &OutputLayout) -> Value {
    let mut samples = Vec::new();
    for f in [0, FRAMES - 1] {
        for v in 0..3 {
            for k in [0, 5, layout.coordinates.len() - 1] {
                samples.push(
                    json!({"kind": "nodal", "variable": layout.nodal_variables[v],
                    "step": f, "node": k, "value": nodal(f, v, k)}),
                );
            }
        }
        for (b, block) in layout.blocks.iter().enumerate() {
            for v in 0..2 {
                let e = block.nodes.len() - 1;
                samples.push(
                    json!({"kind": "element", "variable": layout.element_variables[v],
                    "block_index": b, "block_id": block.id, "step": f, "element": e,
                    "value": element(f, v, block.nodes[e] as usize)}),
                );
            }
        }
        for v in 0..2 {
            samples.push(
                json!({"kind": "global", "variable": layout.global_variables[v],
                "step": f, "value": global(f, v)}),
            );
        }
    }
    json!({
        "title": layout.title,
        "num_nodes": layout.coordinates.len(),
        "coordinates": layout.coordinates,
        "node_ids": layout.node_ids,
        "blocks": layout.blocks.iter().map(|b| json!({
            "id": b.id, "name": b.name, "size": b.nodes.len(),
            "nodes": b.nodes.iter().map(|&k| k + 1).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "node_sets": layout.node_sets.iter().map(|s| json!({
            "id": s.id, "name": s.name,
            "nodes": s.nodes.iter().map(|&k| k + 1).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "nodal_variables": layout.nodal_variables,
        "element_variables": layout.element_variables,
        "global_variables": layout.global_variables,
        "times": (0..FRAMES).map(time).collect::<Vec<_>>(),
        "samples": samples,
    })
}

#[test]
fn exodus_round_trip() {
    let layout = layout();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("roundtrip.e");
    write(&path, &layout);
    check(&path, &layout);

    if let Some(keep) = std::env::var_os("PERIDYN_KEEP_FIXTURES") {
        let keep = Path::new(&keep);
        std::fs::create_dir_all(keep).unwrap();
        let kept = keep.join("roundtrip.e");
        write(&kept, &layout);
        check(&kept, &layout);
        let json = serde_json::to_string_pretty(&describe(&layout)).unwrap();
        std::fs::write(keep.join("roundtrip.json"), json).unwrap();
        println!("wrote {} and roundtrip.json", kept.display());
    }
}
