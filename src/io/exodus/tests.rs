//! Tests of the Exodus reader, writer and comparison.

use std::path::{Path, PathBuf};

use super::compare::{QuantityKind, Tolerance, ToleranceKind};
use super::netcdf::NcReader;
use super::*;

/// A layout with 2 blocks, 2 node sets (one unnamed-looking name), and every variable kind.
fn sample_layout() -> OutputLayout {
    // 5 points on a line; ids deliberately not 1..=5 to check the maps.
    OutputLayout {
        title: "peridyn round trip".to_string(),
        coordinates: (0..5)
            .map(|k| [k as f64 * 0.5, 1.0 - k as f64, 0.25])
            .collect(),
        node_ids: vec![11, 12, 13, 14, 15],
        blocks: vec![
            OutputBlock {
                id: 1,
                name: "block_1".to_string(),
                nodes: vec![0, 2, 4],
                undefined: Vec::new(),
            },
            OutputBlock {
                id: 7,
                name: "block_7".to_string(),
                nodes: vec![1, 3],
                undefined: Vec::new(),
            },
        ],
        node_sets: vec![
            OutputNodeSet {
                id: 1,
                name: "Min_X_Node_Set".to_string(),
                nodes: vec![0],
            },
            OutputNodeSet {
                id: 2,
                name: "Right_End".to_string(),
                nodes: vec![3, 4],
            },
        ],
        nodal_variables: vec!["DisplacementX".into(), "DisplacementY".into()],
        element_variables: vec!["Damage".into(), "Volume".into()],
        global_variables: vec!["Kinetic_Energy".into()],
    }
}

/// One frame: time, nodal fields, element fields (per node), global values.
type Frame = (f64, Vec<Vec<f64>>, Vec<Vec<f64>>, Vec<f64>);

/// Field values for frame `f`: distinct per frame, variable and node so mix-ups show.
fn frame_values(f: usize) -> Frame {
    let time = 0.1 * f as f64;
    let nodal = (0..2)
        .map(|v| {
            (0..5)
                .map(|n| (f * 100 + v * 10 + n) as f64 + 0.125)
                .collect()
        })
        .collect();
    let element = (0..2)
        .map(|v| {
            (0..5)
                .map(|n| -((f * 100 + v * 10 + n) as f64) / 3.0)
                .collect()
        })
        .collect();
    (time, nodal, element, vec![f as f64 * 1e-3 + 1.0 / 7.0])
}

fn write_frames(path: &Path, frames: usize) -> ExodusWriter {
    let mut writer = ExodusWriter::create(path, &sample_layout()).unwrap();
    for f in 0..frames {
        let (t, nodal, element, global) = frame_values(f);
        let nodal: Vec<&[f64]> = nodal.iter().map(Vec::as_slice).collect();
        let element: Vec<&[f64]> = element.iter().map(Vec::as_slice).collect();
        writer.write_frame(t, &nodal, &element, &global).unwrap();
    }
    writer
}

fn check_frames(file: &ExodusFile, frames: usize) {
    let layout = sample_layout();
    assert_eq!(file.times.len(), frames);
    for f in 0..frames {
        let (t, nodal, element, global) = frame_values(f);
        assert_eq!(file.times[f], t);
        for (v, expected) in nodal.iter().enumerate() {
            assert_eq!(&file.nodal_values(f, v).unwrap(), expected);
        }
        for (b, block) in layout.blocks.iter().enumerate() {
            for (v, field) in element.iter().enumerate() {
                let expected: Vec<f64> = block.nodes.iter().map(|&n| field[n as usize]).collect();
                assert_eq!(file.element_values(f, v, b).unwrap(), Some(expected));
            }
        }
        assert_eq!(file.global_values(f).unwrap(), global);
    }
}

#[test]
fn a_variable_undefined_on_a_block_has_a_zero_truth_table_entry_and_no_values_there() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("truth.e");
    let mut layout = sample_layout();
    layout.blocks[1].undefined = vec!["Damage".into()];
    let mut writer = ExodusWriter::create(&path, &layout).unwrap();
    let (t, nodal, element, global) = frame_values(0);
    let nodal: Vec<&[f64]> = nodal.iter().map(Vec::as_slice).collect();
    let element: Vec<&[f64]> = element.iter().map(Vec::as_slice).collect();
    writer.write_frame(t, &nodal, &element, &global).unwrap();
    writer.finish().unwrap();
    let file = ExodusFile::open(&path).unwrap();
    for (b, block) in layout.blocks.iter().enumerate() {
        for (v, field) in element.iter().enumerate() {
            let expected: Vec<f64> = block.nodes.iter().map(|&n| field[n as usize]).collect();
            let read = file.element_values(0, v, b).unwrap();
            if b == 1 && v == 0 {
                assert_eq!(read, None, "Damage is not defined on block 7");
            } else {
                assert_eq!(read, Some(expected), "variable {v} on block {b}");
            }
        }
    }
}

#[test]
fn round_trip_preserves_mesh_names_and_values_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rt.e");
    let writer = write_frames(&path, 3);
    assert_eq!(writer.frames_written(), 3);
    writer.finish().unwrap();

    let file = ExodusFile::open(&path).unwrap();
    let layout = sample_layout();
    assert_eq!(file.title, layout.title);
    assert_eq!(file.dimension, 3);
    assert_eq!(file.coordinates, layout.coordinates);
    assert_eq!(file.node_ids, layout.node_ids);
    // Elements are numbered block by block; each carries the id of its point.
    assert_eq!(file.element_ids, vec![11, 13, 15, 12, 14]);
    assert_eq!(file.blocks.len(), 2);
    for (read, written) in file.blocks.iter().zip(&layout.blocks) {
        assert_eq!(read.id, written.id);
        assert_eq!(read.name, written.name);
        assert_eq!(read.element_type, "SPHERE");
        assert_eq!(read.nodes_per_element, 1);
        assert_eq!(read.connectivity, written.nodes);
    }
    assert_eq!(file.node_sets.len(), 2);
    for (read, written) in file.node_sets.iter().zip(&layout.node_sets) {
        assert_eq!(
            (read.id, &read.name, &read.nodes),
            (written.id, &written.name, &written.nodes)
        );
    }
    assert_eq!(file.nodal_variable_names, layout.nodal_variables);
    assert_eq!(file.element_variable_names, layout.element_variables);
    assert_eq!(file.global_variable_names, layout.global_variables);
    check_frames(&file, 3);
}

#[test]
fn file_dropped_after_two_of_three_frames_is_readable_with_two() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.e");
    let writer = write_frames(&path, 2);
    // A run that dies after frame 2: the writer is dropped without finish().
    drop(writer);
    let file = ExodusFile::open(&path).unwrap();
    check_frames(&file, 2);
}

#[test]
fn file_is_valid_while_the_writer_is_still_open() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("live.e");
    let writer = write_frames(&path, 1);
    let file = ExodusFile::open(&path).unwrap();
    check_frames(&file, 1);
    writer.finish().unwrap();
}

#[test]
fn empty_block_and_node_set_become_null_entities() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("null.e");
    let mut layout = sample_layout();
    layout.blocks[1].nodes.clear();
    layout.node_sets[0].nodes.clear();
    let mut writer = ExodusWriter::create(&path, &layout).unwrap();
    let field = [1.0, 2.0, 3.0, 4.0, 5.0];
    writer
        .write_frame(0.5, &[&field, &field], &[&field, &field], &[9.0])
        .unwrap();
    writer.finish().unwrap();
    let file = ExodusFile::open(&path).unwrap();
    assert_eq!(file.blocks[1].num_elements(), 0);
    assert!(file.node_sets[0].nodes.is_empty());
    assert_eq!(file.element_values(0, 0, 1).unwrap(), None);
    // Block 1 holds nodes 0, 2, 4 → values 1, 3, 5.
    assert_eq!(
        file.element_values(0, 1, 0).unwrap(),
        Some(vec![1.0, 3.0, 5.0])
    );
}

#[test]
fn writer_rejects_inconsistent_input_with_clear_messages() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.e");
    let mut layout = sample_layout();
    layout.blocks[0].nodes.push(99);
    let err = ExodusWriter::create(&path, &layout)
        .unwrap_err()
        .to_string();
    assert!(err.contains("bad.e") && err.contains("node 99"), "{err}");

    let mut writer = ExodusWriter::create(&path, &sample_layout()).unwrap();
    let short = [1.0; 4];
    let err = writer
        .write_frame(0.0, &[&short, &short], &[&short, &short], &[0.0])
        .unwrap_err()
        .to_string();
    assert!(err.contains("4 values") && err.contains("(5)"), "{err}");
    let err = writer
        .write_frame(0.0, &[], &[], &[])
        .unwrap_err()
        .to_string();
    assert!(err.contains("0 nodal fields"), "{err}");
    assert_eq!(writer.frames_written(), 0);
}

#[test]
fn long_names_widen_len_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.e");
    let mut layout = sample_layout();
    let long = "A_Very_Long_Node_Set_Name_That_Exceeds_32_Characters".to_string();
    layout.node_sets[1].name = long.clone();
    write_frames_with(&path, &layout);
    let file = ExodusFile::open(&path).unwrap();
    assert_eq!(file.node_sets[1].name, long);
}

fn write_frames_with(path: &Path, layout: &OutputLayout) {
    let writer = ExodusWriter::create(path, layout).unwrap();
    writer.finish().unwrap();
}

#[test]
fn reader_errors_name_the_file_and_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let text = dir.path().join("not_netcdf.e");
    std::fs::write(&text, "hello world, not a netCDF file").unwrap();
    let err = ExodusFile::open(&text).unwrap_err().to_string();
    assert!(
        err.contains("not_netcdf.e") && err.contains("not a netCDF-3 file"),
        "{err}"
    );

    let missing = dir.path().join("missing.e");
    let err = ExodusFile::open(&missing).unwrap_err().to_string();
    assert!(
        err.contains("missing.e") && err.contains("cannot open"),
        "{err}"
    );

    // Cut a valid file where its last fixed-size variable starts.
    let good = dir.path().join("good.e");
    write_frames(&good, 2).finish().unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let cut = dir.path().join("cut_fixed.e");
    let reader = NcReader::open(std::fs::File::open(&good).unwrap()).unwrap();
    let last_fixed_end = reader
        .header
        .vars
        .iter()
        .filter(|v| !reader.header.is_record_var(v))
        .map(|v| v.begin)
        .max()
        .unwrap();
    std::fs::write(&cut, &bytes[..last_fixed_end as usize]).unwrap();
    let err = ExodusFile::open(&cut).unwrap_err().to_string();
    assert!(
        err.contains("cut_fixed.e") && err.contains("truncated"),
        "{err}"
    );

    // Cut in the middle of the second record: the header still announces 2 records.
    let cut = dir.path().join("cut_record.e");
    std::fs::write(&cut, &bytes[..bytes.len() - 20]).unwrap();
    let err = ExodusFile::open(&cut).unwrap_err().to_string();
    assert!(
        err.contains("announces 2 records") && err.contains("only 1"),
        "{err}"
    );

    let file = ExodusFile::open(&good).unwrap();
    let err = file.nodal_values(5, 0).unwrap_err().to_string();
    assert!(
        err.contains("time step 5") && err.contains("2 steps"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// Peridigm's files
// ---------------------------------------------------------------------------------------------

/// Peridigm's decks and gold results (its `examples` and `test/regression` folders), if present:
/// `$PERIDIGM_DATA`, else `../shared/peridigm` beside the checkout, where CI puts them.
fn peridigm_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("PERIDIGM_DATA").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/peridigm"),
        PathBuf::from,
    );
    if dir.is_dir() {
        Some(dir)
    } else {
        println!(
            "NOTE: {} not found; skipping the Peridigm data test",
            dir.display()
        );
        None
    }
}

fn files_with_extension(dir: &Path, extensions: &[&str], out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            files_with_extension(&path, extensions, out);
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| extensions.contains(&e))
        {
            out.push(path);
        }
    }
    out.sort();
}

#[test]
fn reads_every_peridigm_mesh_and_result() {
    let Some(dir) = peridigm_dir() else { return };
    let mut files = Vec::new();
    files_with_extension(&dir, &["g", "e", "h"], &mut files);
    assert!(!files.is_empty(), "no Exodus files under {}", dir.display());
    for path in &files {
        let file = ExodusFile::open(path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(file.node_ids.len(), file.coordinates.len());
        assert_eq!(file.element_ids.len(), file.num_elements());
        // Read the last step of every variable to exercise the record layout.
        if let Some(last) = file.times.len().checked_sub(1) {
            for v in 0..file.nodal_variable_names.len() {
                let values = file.nodal_values(last, v).unwrap();
                assert_eq!(values.len(), file.coordinates.len(), "{}", path.display());
            }
            for v in 0..file.element_variable_names.len() {
                for b in 0..file.blocks.len() {
                    if let Some(values) = file.element_values(last, v, b).unwrap() {
                        assert_eq!(values.len(), file.blocks[b].num_elements());
                    }
                }
            }
            let globals = file.global_values(last).unwrap();
            assert_eq!(globals.len(), file.global_variable_names.len());
        }
    }
    println!("read {} Peridigm Exodus files", files.len());
}

#[test]
fn peridigm_files_have_the_expected_content() {
    let Some(dir) = peridigm_dir() else { return };
    let regression = dir.join("test/regression");
    // Values below were read with netCDF4-python from the same files.
    let wave = ExodusFile::open(&regression.join("WaveInBar/WaveInBar_gold.e")).unwrap();
    assert_eq!(wave.title, "Peridigm");
    assert_eq!(wave.blocks[0].element_type, "SPHERE");
    assert_eq!(wave.times.len(), 12);
    assert!(wave
        .nodal_variable_names
        .iter()
        .any(|n| n == "DisplacementX"));

    let cubes = ExodusFile::open(&regression.join("Contact_Cubes/Contact_Cubes_gold.e")).unwrap();
    assert_eq!(cubes.coordinates.len(), 128);
    assert_eq!(
        cubes.global_variable_names,
        [
            "Global_Kinetic_Energy",
            "Block_1_Stored_Elastic_Energy",
            "Block_2_Stored_Elastic_Energy"
        ]
    );
    let names: Vec<&str> = cubes.node_sets.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["NODELIST_1", "NODELIST_2", "RANK_DEFICIENT_NODES"]);
    // ns_status = 0 for the third set: a null node set without node_ns3.
    assert_eq!(
        cubes
            .node_sets
            .iter()
            .map(|s| s.nodes.len())
            .collect::<Vec<_>>(),
        [64, 64, 0]
    );
    // Reference values printed by netCDF4-python (time_whole[-1], vals_glo_var[-1],
    // vals_nod_var1[5][17], vals_elem_var3eb2[5][10], coordx[100]).
    assert_eq!(cubes.times.len(), 20);
    assert_eq!(cubes.times[19], 0.9654867021812208);
    assert_eq!(
        cubes.global_values(19).unwrap(),
        [
            0.007528349052193788,
            9.879789274630182e-05,
            9.879789272069736e-05
        ]
    );
    assert_eq!(cubes.nodal_values(5, 0).unwrap()[17], 0.2540754479424278);
    let dilatation = cubes.element_variable_index("Dilatation").unwrap();
    assert_eq!(
        cubes.element_values(5, dilatation, 1).unwrap().unwrap()[10],
        1.3663806737105932e-15
    );
    assert_eq!(cubes.coordinates[100][0], 1.125);

    // SPHERE mesh with attributes (radius, volume) and unnamed node sets.
    let meshfree = ExodusFile::open(
        &regression.join("Notched_Plate_Data_Loader/Notched_Plate_Data_Loader_Meshfree.g"),
    )
    .unwrap();
    let block = &meshfree.blocks[0];
    assert_eq!(block.attributes_per_element, 2);
    assert_eq!(block.attributes.len(), 2 * block.num_elements());
    // netCDF4-python: attrib1[4] = (0.32455729605581285, 0.034188034188034226),
    // node_ns2[:3] = (217, 220, 226), 1-based.
    assert_eq!(
        block.attributes[8..10],
        [0.32455729605581285, 0.034188034188034226]
    );
    assert_eq!(meshfree.node_sets[1].nodes[..3], [216, 219, 225]);
    let names: Vec<&str> = meshfree.node_sets.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["nodelist_1", "nodelist_2", "nodelist_3"]);

    // Single-precision results (floating_point_word_size 4) with QUAD4/TRI3 blocks.
    let interfaces = ExodusFile::open(&regression.join("Interfaces/Interfaces_gold.e")).unwrap();
    let types: Vec<&str> = interfaces
        .blocks
        .iter()
        .map(|b| b.element_type.as_str())
        .collect();
    assert_eq!(types, ["QUAD4", "TRI3"]);
    assert_eq!(interfaces.blocks[0].nodes_per_element, 4);
    // netCDF4-python: time_whole[1] = 1.0 (float32), connect2[3] = (153, 134, 154), 1-based.
    assert_eq!(interfaces.times, [0.0, 1.0]);
    assert_eq!(interfaces.blocks[1].connectivity[9..12], [152, 133, 153]);

    // Hex mesh with named node sets.
    let bar = ExodusFile::open(&regression.join("Bar_OneBlock_OneMaterial_QS/Bar.g")).unwrap();
    assert_eq!(bar.blocks[0].element_type, "HEX8");
    assert_eq!(bar.blocks[0].nodes_per_element, 8);
    assert!(bar.times.is_empty());
}

/// Copies `gold` and adds `delta` to one value of nodal variable `variable` at `step`, node
/// `node`, by patching the bytes of the netCDF record (everything else stays identical).
fn perturbed_copy(gold: &Path, out: &Path, variable: usize, step: usize, node: usize, delta: f64) {
    let reader = NcReader::open(std::fs::File::open(gold).unwrap()).unwrap();
    let var = reader
        .header
        .var(&format!("vals_nod_var{}", variable + 1))
        .unwrap();
    let offset = (var.begin + step as u64 * reader.header.record_size() + node as u64 * 8) as usize;
    let mut bytes = std::fs::read(gold).unwrap();
    let old = f64::from_be_bytes(bytes[offset..offset + 8].try_into().unwrap());
    bytes[offset..offset + 8].copy_from_slice(&(old + delta).to_be_bytes());
    std::fs::write(out, bytes).unwrap();
}

#[test]
fn gold_file_matches_itself_and_a_perturbed_copy_fails_on_that_variable() {
    let Some(dir) = peridigm_dir() else { return };
    let case = dir.join("test/regression/WaveInBar");
    let gold_path = case.join("WaveInBar_gold.e");
    let spec = ComparisonSpec::from_file(&case.join("WaveInBar.comp")).unwrap();
    let gold = ExodusFile::open(&gold_path).unwrap();

    let report = compare(&gold, &gold, &spec).unwrap();
    assert!(report.passed(), "{report}");

    let variable = gold.nodal_variable_index("DisplacementY").unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let perturbed_path = tmp.path().join("perturbed.e");
    // WaveInBar.comp: DisplacementY absolute 5.0E-14 → a change of 1e-6 must fail.
    perturbed_copy(&gold_path, &perturbed_path, variable, 7, 3, 1e-6);
    let perturbed = ExodusFile::open(&perturbed_path).unwrap();
    let report = compare(&gold, &perturbed, &spec).unwrap();
    assert!(!report.passed());
    let failures = report.failures();
    assert_eq!(failures.len(), 1, "{report}");
    assert_eq!(failures[0].name, "DisplacementY");
    assert_eq!((failures[0].step, failures[0].index), (Some(7), 3));
    assert!((failures[0].difference - 1e-6).abs() < 1e-12);
    assert!(report.to_string().contains("DisplacementY"), "{report}");

    // A change below the tolerance (1e-14 < 5e-14) passes.
    perturbed_copy(&gold_path, &perturbed_path, variable, 7, 3, 1e-14);
    let perturbed = ExodusFile::open(&perturbed_path).unwrap();
    assert!(compare(&gold, &perturbed, &spec).unwrap().passed());
}

#[test]
fn every_regression_comp_file_parses() {
    let Some(dir) = peridigm_dir() else { return };
    let mut files = Vec::new();
    files_with_extension(&dir, &["comp"], &mut files);
    assert!(!files.is_empty());
    for path in &files {
        let spec = ComparisonSpec::from_file(path).unwrap_or_else(|e| panic!("{e}"));
        let sections = [&spec.global, &spec.nodal, &spec.element];
        assert!(
            sections.iter().any(|s| s.is_some()),
            "{}: no VARIABLES section",
            path.display()
        );
    }
    println!("parsed {} .comp files", files.len());
}

#[test]
fn every_gold_file_matches_itself_under_its_comp_file() {
    let Some(dir) = peridigm_dir() else { return };
    let mut comps = Vec::new();
    files_with_extension(&dir.join("test/regression"), &["comp"], &mut comps);
    let mut checked = 0;
    for comp in comps {
        let spec = ComparisonSpec::from_file(&comp).unwrap();
        let mut golds = Vec::new();
        files_with_extension(comp.parent().unwrap(), &["e", "h"], &mut golds);
        for gold in golds
            .iter()
            .filter(|g| g.to_string_lossy().contains("_gold"))
        {
            let file = ExodusFile::open(gold).unwrap();
            let report = compare(&file, &file, &spec).unwrap();
            // Identical files can still "differ" only through NaNs or listed-but-absent names.
            let missing_listed = report.structural.iter().all(|s| s.contains("command file"));
            assert!(
                report.failures().is_empty() && missing_listed,
                "{}: {report}",
                gold.display()
            );
            checked += 1;
        }
    }
    assert!(checked > 10);
}

// ---------------------------------------------------------------------------------------------
// Command files and tolerances
// ---------------------------------------------------------------------------------------------

#[test]
fn tolerance_formulas_follow_exodiff() {
    let rel = Tolerance {
        kind: ToleranceKind::Relative,
        value: 1e-6,
        floor: 0.0,
    };
    // |a−b|/max(|a|,|b|) = 1e-6/1.000001 < 1e-6 → equal; 2e-6/1.000002 > 1e-6 → different.
    assert!(!rel.exceeded(1.0, 1.000001));
    assert!(rel.exceeded(1.0, 1.000002));
    assert!(!rel.exceeded(0.0, 0.0));
    // Relative: 0 vs tiny is a 100 % difference unless a floor hides it.
    assert!(rel.exceeded(0.0, 1e-300));
    let floored = Tolerance {
        floor: 1e-12,
        ..rel
    };
    assert!(!floored.exceeded(0.0, 1e-13));
    // Floor needs *both* values small (exodiff's current rule, not |a−b| < floor).
    assert!(floored.exceeded(1e-13, 1e-11));
    let abs = Tolerance {
        kind: ToleranceKind::Absolute,
        value: 1e-9,
        floor: 0.0,
    };
    assert!(!abs.exceeded(5.0, 5.0 + 5e-10));
    assert!(abs.exceeded(5.0, 5.0 + 2e-9));
    assert!(abs.exceeded(f64::NAN, 1.0));
    let combined = Tolerance {
        kind: ToleranceKind::Combined,
        value: 1e-3,
        floor: 0.0,
    };
    // Below 1 it is absolute: |0.5 − 0.5015| = 1.5e-3 ≥ 1e-3; above 1 relative to max.
    assert!(combined.exceeded(0.5, 0.5015));
    assert!(!combined.exceeded(1000.0, 1000.5));
    let eigen = Tolerance {
        kind: ToleranceKind::EigenAbsolute,
        value: 1e-9,
        floor: 0.0,
    };
    assert!(!eigen.exceeded(-2.0, 2.0));
}

#[test]
fn command_file_sections_restrict_and_override() {
    let text = "# comment line\n\
        DEFAULT TOLERANCE absolute 1.0E-9\n\
        COORDINATES absolute 1.0E-12\n\
        TIME STEPS absolute 1.0E-14\n\
        NODAL VARIABLES absolute 1.0E-12\n\
        \tDisplacementX   absolute 5.0E-14\n\
        \tVelocityX\n\
        \tForceX relative 1.e-6 floor 0.0\n\
        \tForceY relative floor 1e-10   # keeps the section value\n\
        \n\
        ELEMENT VARIABLES (all) relative 1.e-6 floor 1e-20\n\
        \t!Proc_Num\n\
        \tDamage absolute 0.5\n";
    let spec = ComparisonSpec::parse(text).unwrap();
    let abs = |value| Tolerance {
        kind: ToleranceKind::Absolute,
        value,
        floor: 0.0,
    };
    assert_eq!(spec.coordinates, abs(1e-12));
    assert_eq!(spec.time_steps, abs(1e-14));
    assert!(
        spec.global.is_none(),
        "no GLOBAL VARIABLES line → globals not compared"
    );
    let nodal = spec.nodal.as_ref().unwrap();
    assert_eq!(nodal.tolerance_for("DisplacementX", true), Some(abs(5e-14)));
    assert_eq!(nodal.tolerance_for("displacementx", true), Some(abs(5e-14)));
    assert_eq!(nodal.tolerance_for("VelocityX", true), Some(abs(1e-12)));
    assert_eq!(
        nodal.tolerance_for("ForceX", true),
        Some(Tolerance {
            kind: ToleranceKind::Relative,
            value: 1e-6,
            floor: 0.0
        })
    );
    assert_eq!(
        nodal.tolerance_for("ForceY", true),
        Some(Tolerance {
            kind: ToleranceKind::Relative,
            value: 1e-12,
            floor: 1e-10
        })
    );
    // Listed names restrict the comparison.
    assert_eq!(nodal.tolerance_for("VelocityY", true), None);
    let element = spec.element.as_ref().unwrap();
    assert_eq!(element.tolerance_for("Proc_Num", true), None);
    // A variable without its own floor takes the section's (exodiff's rule).
    assert_eq!(
        element.tolerance_for("Damage", true),
        Some(Tolerance {
            floor: 1e-20,
            ..abs(0.5)
        })
    );
    assert_eq!(
        element.tolerance_for("Dilatation", true),
        Some(Tolerance {
            kind: ToleranceKind::Relative,
            value: 1e-6,
            floor: 1e-20
        })
    );
}

#[test]
fn defaults_without_command_file_are_exodiffs() {
    let spec = ComparisonSpec::default();
    assert_eq!(spec.coordinates, Tolerance::DEFAULT_COORDINATES);
    assert_eq!(spec.time_steps.floor, 1e-15);
    let nodal = spec.nodal.as_ref().unwrap();
    assert_eq!(
        nodal.tolerance_for("Anything", true),
        Some(Tolerance::DEFAULT_VARIABLES)
    );
    // TIME STEPS without values inherits DEFAULT TOLERANCE, floor included.
    let spec =
        ComparisonSpec::parse("DEFAULT TOLERANCE relative 1e-8 floor 1e-14\nTIME STEPS\n").unwrap();
    assert_eq!(
        spec.time_steps,
        Tolerance {
            kind: ToleranceKind::Relative,
            value: 1e-8,
            floor: 1e-14
        }
    );
}

#[test]
fn command_file_errors_name_the_line() {
    let err = ComparisonSpec::parse("NODAL VARIABLES absolute\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(":1:") && err.contains("tolerance value"),
        "{err}"
    );
    let err = ComparisonSpec::parse("COORDINATES absolute 1e-6\nFOO BAR\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains(":2:") && err.contains("FOO BAR"), "{err}");
    let err = ComparisonSpec::parse("\tDisplacementX\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("outside"), "{err}");
    let err = ComparisonSpec::parse("NODAL VARIABLES\n\tA\n\t!B\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("(all)"), "{err}");
    let err = ComparisonSpec::parse("DEFAULT TOLERANCE absolute -1\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("non-negative"), "{err}");
}

#[test]
fn comparison_reports_structure_and_worst_values() {
    let dir = tempfile::tempdir().unwrap();
    let a_path = dir.path().join("a.e");
    write_frames(&a_path, 3).finish().unwrap();
    let b_path = dir.path().join("b.e");
    write_frames(&b_path, 2).finish().unwrap();
    let a = ExodusFile::open(&a_path).unwrap();
    let b = ExodusFile::open(&b_path).unwrap();
    let report = compare(&a, &a, &ComparisonSpec::default()).unwrap();
    assert!(report.passed(), "{report}");
    // 3 coordinate axes + time + 1 global + 2 nodal + 2 element variables × 2 blocks.
    assert_eq!(report.quantities.len(), 3 + 1 + 1 + 2 + 4);

    let report = compare(&a, &b, &ComparisonSpec::default()).unwrap();
    assert!(!report.passed());
    assert!(
        report.structural.iter().any(|s| s.contains("3 time steps")),
        "{report}"
    );
    // The common steps still compare equal.
    assert!(report.failures().is_empty());

    // Element variables are compared per block id; a different value in block 7 is found.
    let c_path = dir.path().join("c.e");
    let mut writer = ExodusWriter::create(&c_path, &sample_layout()).unwrap();
    for f in 0..3 {
        let (t, nodal, mut element, global) = frame_values(f);
        if f == 2 {
            element[1][3] += 1.0; // node 3 is the 2nd element of block 7
        }
        let nodal: Vec<&[f64]> = nodal.iter().map(Vec::as_slice).collect();
        let element: Vec<&[f64]> = element.iter().map(Vec::as_slice).collect();
        writer.write_frame(t, &nodal, &element, &global).unwrap();
    }
    writer.finish().unwrap();
    let c = ExodusFile::open(&c_path).unwrap();
    let report = compare(&a, &c, &ComparisonSpec::default()).unwrap();
    let failures = report.failures();
    assert_eq!(failures.len(), 1, "{report}");
    let worst = failures[0];
    assert_eq!(
        (worst.kind, worst.name.as_str()),
        (QuantityKind::Element, "Volume")
    );
    assert_eq!(
        (worst.block_id, worst.step, worst.index),
        (Some(7), Some(2), 1)
    );
    assert_eq!(worst.failures, 1);
}

/// The content of a Peridigm results file (one SPHERE element per node) as an [`OutputLayout`]
/// plus the frames; `None` if the file does not have that shape.
fn as_layout(file: &ExodusFile) -> Option<OutputLayout> {
    let sphere_per_node = file
        .blocks
        .iter()
        .all(|b| b.element_type == "SPHERE" && b.nodes_per_element == 1);
    let defined_everywhere = file
        .element_variable_defined
        .iter()
        .zip(&file.blocks)
        .all(|(row, b)| b.num_elements() == 0 || row.iter().all(|&d| d));
    if !sphere_per_node || !defined_everywhere || file.num_elements() != file.coordinates.len() {
        return None;
    }
    Some(OutputLayout {
        title: file.title.clone(),
        coordinates: file.coordinates.clone(),
        node_ids: file.node_ids.clone(),
        blocks: file
            .blocks
            .iter()
            .map(|b| OutputBlock {
                id: b.id,
                name: b.name.clone(),
                nodes: b.connectivity.clone(),
                undefined: Vec::new(),
            })
            .collect(),
        node_sets: file
            .node_sets
            .iter()
            .map(|s| OutputNodeSet {
                id: s.id,
                name: s.name.clone(),
                nodes: s.nodes.clone(),
            })
            .collect(),
        nodal_variables: file.nodal_variable_names.clone(),
        element_variables: file.element_variable_names.clone(),
        global_variables: file.global_variable_names.clone(),
    })
}

#[test]
fn rewriting_peridigm_gold_files_with_our_writer_reproduces_them_exactly() {
    let Some(dir) = peridigm_dir() else { return };
    let mut files = Vec::new();
    files_with_extension(&dir.join("test/regression"), &["e", "h"], &mut files);
    let exact = Tolerance {
        kind: ToleranceKind::Absolute,
        value: 0.0,
        floor: 0.0,
    };
    let spec = ComparisonSpec {
        coordinates: exact,
        time_steps: exact,
        global: Some(compare::VariableSection::all_with(exact)),
        nodal: Some(compare::VariableSection::all_with(exact)),
        element: Some(compare::VariableSection::all_with(exact)),
        ignore_case: false,
    };
    let tmp = tempfile::tempdir().unwrap();
    let mut rewritten = 0;
    for path in &files {
        let gold = ExodusFile::open(path).unwrap();
        let Some(layout) = as_layout(&gold) else {
            println!(
                "not a one-sphere-per-point file, skipped: {}",
                path.display()
            );
            continue;
        };
        let out = tmp.path().join("rewritten.e");
        let mut writer = ExodusWriter::create(&out, &layout).unwrap();
        let n = gold.coordinates.len();
        for step in 0..gold.times.len() {
            let nodal: Vec<Vec<f64>> = (0..layout.nodal_variables.len())
                .map(|v| gold.nodal_values(step, v).unwrap())
                .collect();
            // Element values back to per-node arrays through the connectivity.
            let mut element = vec![vec![0.0; n]; layout.element_variables.len()];
            for (b, block) in gold.blocks.iter().enumerate() {
                for (v, field) in element.iter_mut().enumerate() {
                    if let Some(values) = gold.element_values(step, v, b).unwrap() {
                        for (&node, value) in block.connectivity.iter().zip(values) {
                            field[node as usize] = value;
                        }
                    }
                }
            }
            let nodal: Vec<&[f64]> = nodal.iter().map(Vec::as_slice).collect();
            let element: Vec<&[f64]> = element.iter().map(Vec::as_slice).collect();
            writer
                .write_frame(
                    gold.times[step],
                    &nodal,
                    &element,
                    &gold.global_values(step).unwrap(),
                )
                .unwrap();
        }
        writer.finish().unwrap();
        let copy = ExodusFile::open(&out).unwrap();
        let report = compare(&gold, &copy, &spec).unwrap();
        assert!(report.passed(), "{}: {report}", path.display());
        assert_eq!(copy.node_sets, gold.node_sets, "{}", path.display());
        assert_eq!(copy.element_ids, gold.element_ids, "{}", path.display());
        rewritten += 1;
    }
    println!("rewrote {rewritten} gold files exactly");
    assert!(
        rewritten > 30,
        "only {rewritten} gold files could be rewritten"
    );
}

#[test]
fn file_without_variables_stores_only_times() {
    // time_whole is then the only record variable: netCDF's unpadded single-variable record.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("times.e");
    let mut layout = sample_layout();
    layout.nodal_variables.clear();
    layout.element_variables.clear();
    layout.global_variables.clear();
    let mut writer = ExodusWriter::create(&path, &layout).unwrap();
    for t in [0.0, 0.25, 2.5] {
        writer.write_frame(t, &[], &[], &[]).unwrap();
    }
    writer.finish().unwrap();
    let file = ExodusFile::open(&path).unwrap();
    assert_eq!(file.times, [0.0, 0.25, 2.5]);
    assert!(file.global_values(2).unwrap().is_empty());
    assert_eq!(file.element_variable_defined, vec![Vec::<bool>::new(); 2]);
}

#[test]
fn conjoined_files_read_as_one_time_series() {
    let dir = tempfile::tempdir().unwrap();
    let first = dir.path().join("first.e");
    let second = dir.path().join("second.e");
    write_frames(&first, 2).finish().unwrap();
    // The second file holds frames 0..3 of the same series; read after the first two, its
    // frames become steps 2..5 of the joined series.
    write_frames(&second, 3).finish().unwrap();
    let joined = ExodusFile::open_conjoined(&[&first, &second]).unwrap();
    assert_eq!(joined.times, vec![0.0, 0.1, 0.0, 0.1, 0.2]);
    let alone = ExodusFile::open(&second).unwrap();
    for step in 0..3 {
        assert_eq!(
            joined.nodal_values(2 + step, 1).unwrap(),
            alone.nodal_values(step, 1).unwrap()
        );
        assert_eq!(
            joined.element_values(2 + step, 0, 0).unwrap(),
            alone.element_values(step, 0, 0).unwrap()
        );
        assert_eq!(
            joined.global_values(2 + step).unwrap(),
            alone.global_values(step).unwrap()
        );
    }
    assert!(joined.nodal_values(5, 0).is_err(), "past the last frame");
}
