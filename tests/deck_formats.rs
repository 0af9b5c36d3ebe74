//! YAML and XML give the same deck; typed values, defaults, paths and line lookup.

mod deck_common;

use std::path::Path;

use deck_common::*;
use peridyn::damage::{CriticalStretchLimit, CriticalStretchParameters};
use peridyn::io::deck::{
    self, BondFilterShape, BoundaryConditionKind, ComputeClassKind, ContactInteraction, Coordinate,
    Friction, Horizon, InfluenceFunction, Integrator, LoadSteps, NodeSetSource, OmitBonds,
    ParameterValue, PeridigmPreconditioner, PointSource,
};
use peridyn::material::{LinearPeridynamicSolidParameters, PlasticityInput};

#[test]
fn yaml_and_xml_twins_load_to_equal_decks() {
    let dir = tempfile::tempdir().expect("temporary directory");
    let yaml_path = dir.path().join("twin.yaml");
    let xml_path = dir.path().join("twin.xml");
    std::fs::write(&yaml_path, TWIN_YAML).unwrap();
    std::fs::write(&xml_path, TWIN_XML).unwrap();
    let from_yaml = deck::load(&yaml_path).expect("YAML twin loads");
    let from_xml = deck::load(&xml_path).expect("XML twin loads");
    assert_eq!(from_yaml, from_xml);
    assert_eq!(from_yaml.format, deck::DeckFormat::Yaml);
    assert_eq!(from_xml.format, deck::DeckFormat::Xml);
    assert!(from_yaml.warnings.is_empty(), "{:?}", from_yaml.warnings);
    assert!(from_xml.warnings.is_empty(), "{:?}", from_xml.warnings);

    // Relative file names are resolved against the deck's directory, not read.
    assert_eq!(from_yaml.directory(), dir.path());
    match &from_yaml.discretization.source {
        PointSource::Exodus {
            input_mesh_file, ..
        } => assert_eq!(input_mesh_file, &dir.path().join("mesh/plate.g")),
        other => panic!("expected Exodus, got {other:?}"),
    }
    let max_x = from_yaml.node_set("Max X Node Set").expect("deck node set");
    assert_eq!(
        max_x.source,
        NodeSetSource::File(dir.path().join("nodes/max_x.txt"))
    );
}

#[test]
fn twin_content_is_typed_as_written() {
    let deck = yaml(TWIN_YAML).expect("YAML twin loads");
    let d = &deck.discretization;
    assert_eq!(d.influence_function, InfluenceFunction::ParabolicDecay);
    assert_eq!(d.omit_bonds_between_blocks, OmitBonds::All);
    match &d.bond_filters[0].shape {
        // `Bottom_Length: 2` is an int in YAML; accepted as 2.0.
        BondFilterShape::RectangularPlane {
            bottom_length,
            normal,
            ..
        } => {
            assert_eq!(*bottom_length, 2.0);
            assert_eq!(*normal, [0.0, 1.0, 0.0]);
        }
        other => panic!("expected a rectangular plane, got {other:?}"),
    }

    let steel = deck.material("Steel").unwrap();
    assert_eq!(steel.model.deck_name(), "Elastic");
    let elastic = steel
        .parameters::<LinearPeridynamicSolidParameters>()
        .unwrap();
    // K = E/(3(1 − 2ν)) = 200e9/(3·0.5); μ = E/(2(1 + ν)) = 200e9/2.5 (Peridigm's
    // `Material::calculateBulkModulus`, `calculateShearModulus`).
    assert!((elastic.elastic.bulk_modulus - 200.0e9 / 1.5).abs() < 1.0);
    assert!((elastic.elastic.shear_modulus - 80.0e9).abs() < 1.0);
    assert_eq!(steel.thermal_expansion_coefficient, Some(1.2e-5));
    // Defaults of the Elastic model: the model's own tangent, partial stress and shear
    // correction off (Peridigm's `Peridigm_ElasticMaterial.cpp`).
    assert_eq!(steel.tangent, None);
    assert!(!elastic.compute_partial_stress && !elastic.shear_correction);
    let soft = deck.material("Soft").unwrap();
    assert_eq!(soft.model.deck_name(), "Elastic Plastic");
    let plastic = soft.parameters::<PlasticityInput>().unwrap();
    assert_eq!(plastic.yield_stress, 2.5e8);
    assert!(!plastic.disabled && plastic.planar_thickness.is_none());
    assert_eq!(soft.tangent, None);
    let brittle = deck.damage_model("Brittle").unwrap();
    assert_eq!(brittle.model.deck_name(), "Critical Stretch");
    assert_eq!(
        brittle.parameters::<CriticalStretchParameters>(),
        Some(&CriticalStretchParameters {
            limit: CriticalStretchLimit::Stretch(0.001),
            thermal_expansion_coefficient: None
        })
    );

    // `Horizon: 2` (an int) is 2.0; a string horizon is kept as an expression.
    assert_eq!(deck.blocks[0].horizon, Horizon::Constant(2.0));
    assert_eq!(deck.blocks[0].block_names, ["block_1", "block_2"]);
    assert_eq!(deck.blocks[0].damage_model.as_deref(), Some("Brittle"));
    assert_eq!(
        deck.blocks[1].horizon,
        Horizon::Expression("0.5 + 0.1*x".into())
    );
    // `Damage Model: "None"` means no damage model.
    assert_eq!(deck.blocks[1].damage_model, None);

    let contact = deck.contact.as_ref().unwrap();
    assert_eq!(contact.search_frequency, 100);
    assert_eq!(contact.models[0].friction, Friction::Constant(0.1));
    assert_eq!(
        contact.interactions,
        [ContactInteraction::General {
            model: "Spring".into()
        }]
    );

    let bc = &deck.boundary_conditions;
    assert_eq!(bc.create_rank_deficient_node_set, Some(true));
    assert_eq!(
        bc.node_sets[0].source,
        NodeSetSource::Ids(vec![1, 4, 7, 10])
    );
    assert_eq!(bc.node_sets[0].normalized_name, "MIN_X_NODE_SET");
    // `\{ \}` in the YAML (and `&lt;` in the XML) become plain characters in the expression.
    assert_eq!(
        bc.conditions[0].value,
        "if(t < 0.5){ value = 0.01*t; } else{ value = 0.005; }"
    );
    assert_eq!(bc.conditions[0].coordinate, Coordinate::Y);
    // A number as Value keeps its spelling.
    assert_eq!(bc.conditions[1].value, "0.0");
    // Scalar-field conditions default to coordinate x.
    assert_eq!(
        bc.conditions[2].kind,
        BoundaryConditionKind::InitialTemperature
    );
    assert_eq!(bc.conditions[2].coordinate, Coordinate::X);
    assert_eq!(bc.conditions[2].node_set_normalized, "MIN_X_NODE_SET");

    assert_eq!(deck.solvers.len(), 2);
    let first = &deck.solvers[0];
    assert_eq!(
        first.peridigm_preconditioner,
        PeridigmPreconditioner::Block3x3
    );
    match &first.integrator {
        Integrator::NoxQuasiStatic(nox) => {
            assert_eq!(nox.load_steps, LoadSteps::Count(4));
            assert_eq!(nox.max_solver_iterations, 20);
            // Defaults from Peridigm's executeNOXQuasiStatic (peridigm.md §1.6).
            assert_eq!(nox.max_age_of_prec, 200);
            assert_eq!(nox.direction_method, "Newton");
            let keys: Vec<&str> = nox.nox.iter().map(|(k, _)| k.as_str()).collect();
            assert_eq!(keys, ["Nonlinear Solver", "Direction", "Line Search"]);
            let ParameterValue::List(direction) = &nox.nox[1].1 else {
                panic!("Direction is a list")
            };
            let ParameterValue::List(newton) = &direction[1].1 else {
                panic!("Newton is a list")
            };
            let ParameterValue::List(linear) = &newton[0].1 else {
                panic!("Linear Solver is a list")
            };
            assert_eq!(
                linear[2],
                ("Max Iterations".to_string(), ParameterValue::Int(200))
            );
        }
        other => panic!("expected NOXQuasiStatic, got {other:?}"),
    }
    match &deck.solvers[1].integrator {
        Integrator::Verlet(v) => assert_eq!((v.fixed_dt, v.safety_factor), (None, 0.8)),
        other => panic!("expected Verlet, got {other:?}"),
    }
    assert_eq!(
        (deck.solvers[1].initial_time, deck.solvers[1].final_time),
        (1.0, 1.5)
    );

    match &deck.compute_classes[1].kind {
        // `Z: 0` is an int; accepted as 0.0.
        ComputeClassKind::NearestPointData { position, .. } => {
            assert_eq!(*position, [0.0, 1.0, 0.0])
        }
        other => panic!("expected Nearest_Point_Data, got {other:?}"),
    }
    let output = &deck.outputs[0];
    assert_eq!(output.frequency, 10);
    // Peridigm's defaults: first step 1, last step INT_MAX − 1 (Peridigm's
    // `Peridigm_OutputManager_ExodusII.cpp`).
    assert_eq!(
        (output.initial_output_step, output.final_output_step),
        (1, 2147483646)
    );
    assert_eq!(
        output.enabled_variables().collect::<Vec<_>>(),
        [
            "Displacement",
            "Damage",
            "Reaction_Force",
            "Gauge_Displacement"
        ]
    );
    assert_eq!(
        output.variables.last(),
        Some(&("Velocity".to_string(), false))
    );
}

#[test]
fn brace_escapes_survive_and_int_horizon_is_a_double() {
    let deck = yaml(BASE_YAML).expect("base deck loads");
    assert_eq!(
        deck.boundary_conditions.conditions[0].value,
        "if(t < 0.5){ value = 0.01*t; } else{ value = 0.005; }"
    );
    // `Horizon: 2` is rejected by Peridigm (issue #9) and accepted here as 2.0.
    assert_eq!(deck.blocks[0].horizon, Horizon::Constant(2.0));
}

#[test]
fn line_of_finds_keys_in_both_formats() {
    let deck = yaml(TWIN_YAML).unwrap();
    assert_eq!(
        deck.line_of(&["Boundary Conditions", "Min X Node Set"]),
        Some(line_containing(TWIN_YAML, "Min X Node Set:"))
    );
    assert_eq!(
        deck.line_of(&["Blocks", "Impactor", "Horizon"]),
        Some(line_containing(TWIN_YAML, "Horizon: \"0.5"))
    );
    assert_eq!(deck.line_of(&["Blocks", "Nowhere"]), None);

    let deck = xml(TWIN_XML).unwrap();
    assert_eq!(
        deck.line_of(&["Boundary Conditions", "Min X Node Set"]),
        Some(line_containing(TWIN_XML, "name=\"Min X Node Set\""))
    );
    assert_eq!(
        deck.line_of(&["Solver1", "NOXQuasiStatic"]),
        Some(line_containing(TWIN_XML, "name=\"NOXQuasiStatic\""))
    );

    // Later (setup-time) errors can name the line too.
    let err = deck.error_at(
        &["Boundary Conditions", "Min X Node Set"],
        "node id 10 exceeds the 8 points of the mesh",
    );
    let line = line_containing(TWIN_XML, "name=\"Min X Node Set\"");
    assert_eq!(err.to_string(), format!("wave.xml:{line}: Boundary Conditions → Min X Node Set: node id 10 exceeds the 8 points of the mesh"));
}

#[test]
fn peridigm_root_key_is_optional() {
    let without_root: String = BASE_YAML
        .lines()
        .skip(1)
        .map(|l| l.strip_prefix("  ").unwrap_or(l))
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(yaml(&without_root).unwrap(), yaml(BASE_YAML).unwrap());
}

#[test]
fn ignored_keys_are_accepted_with_a_warning() {
    let text = base_with(
        "Density: 7800.0",
        "Density: 7800.0\n      Hourglass Coefficient: 0.02",
    );
    let deck = yaml(&text).expect("Peridigm's decks carry this key on Elastic; it must load");
    let line = line_containing(&text, "Hourglass Coefficient");
    assert_eq!(deck.warnings.len(), 1, "{:?}", deck.warnings);
    let w = &deck.warnings[0];
    assert!(
        w.starts_with(&format!(
            "wave.yaml:{line}: Materials → Steel → Hourglass Coefficient:"
        )),
        "{w}"
    );
    assert!(w.contains("no effect"), "{w}");
}

#[test]
fn the_shear_correction_on_elastic_is_applied_with_a_warning_and_off_by_default() {
    let text = base_with(
        "Density: 7800.0",
        "Density: 7800.0\n      Apply Shear Correction Factor: true",
    );
    let deck = yaml(&text).expect("Peridigm's decks use this key on Elastic; it must load");
    let line = line_containing(&text, "Apply Shear Correction Factor");
    assert!(shear_correction(&deck));
    assert_eq!(deck.warnings.len(), 1, "{:?}", deck.warnings);
    let w = &deck.warnings[0];
    assert!(
        w.starts_with(&format!(
            "wave.yaml:{line}: Materials → Steel → Apply Shear Correction Factor:"
        )),
        "{w}"
    );
    assert!(
        w.contains("Peridigm's Elastic reads the key and ignores it"),
        "{w}"
    );
    let off = base_with(
        "Density: 7800.0",
        "Density: 7800.0\n      Apply Shear Correction Factor: false",
    );
    let deck = yaml(&off).unwrap();
    assert!(!shear_correction(&deck));
    assert!(deck.warnings.is_empty(), "{:?}", deck.warnings);
    assert!(!shear_correction(&yaml(BASE_YAML).unwrap()));
}

/// `Apply Shear Correction Factor` of the `Elastic` material `Steel`.
fn shear_correction(deck: &deck::Deck) -> bool {
    deck.material("Steel")
        .unwrap()
        .parameters::<LinearPeridynamicSolidParameters>()
        .unwrap()
        .shear_correction
}

#[test]
fn defaults_when_keys_are_absent() {
    let deck = yaml(BASE_YAML).unwrap();
    assert!(!deck.verbose && deck.restart.is_none() && !deck.multiphysics);
    assert_eq!(
        deck.discretization.influence_function,
        InfluenceFunction::One
    );
    match &deck.solvers[0].integrator {
        Integrator::QuasiStatic(q) => {
            // Defaults from Peridigm's executeQuasiStatic (peridigm.md §1.6).
            assert_eq!(q.relative_tolerance, 1e-6);
            assert_eq!(q.absolute_tolerance, None);
            assert_eq!(q.maximum_solver_iterations, 5);
            assert_eq!(q.belos.relative_tolerance, 1e-4);
        }
        other => panic!("expected QuasiStatic, got {other:?}"),
    }
    let output = &deck.outputs[0];
    assert_eq!(
        (output.file_type.as_str(), output.format.as_str()),
        ("ExodusII", "BINARY")
    );
    // Without `Output Frequency` Peridigm writes nothing (default −1).
    let text = base_with("    Output Frequency: 1\n", "");
    assert_eq!(yaml(&text).unwrap().outputs[0].frequency, -1);
    // Without `Output Filename` the base name is "dump".
    let text = base_with("    Output Filename: \"bar\"\n", "");
    assert_eq!(yaml(&text).unwrap().outputs[0].filename, "dump");
}

#[test]
fn restart_false_is_honoured_with_a_warning() {
    let text = base_with("  Solver:", "  Restart:\n    Restart: false\n  Solver:");
    let deck = yaml(&text).unwrap();
    assert!(deck.restart.is_none());
    assert!(
        deck.warnings
            .iter()
            .any(|w| w.contains("Peridigm would turn restart on")),
        "{:?}",
        deck.warnings
    );
    let text = base_with("  Solver:", "  Restart: true\n  Solver:");
    assert_eq!(yaml(&text).unwrap().restart, Some(Default::default()));
}

#[test]
fn restart_frequency_and_wall_clock_interval_are_read() {
    let text = base_with(
        "  Solver:",
        "  Restart:\n    Frequency: 100\n    Wall Clock Interval: 3600.0\n  Solver:",
    );
    let restart = yaml(&text).unwrap().restart.expect("restart is on");
    assert_eq!(restart.every_steps, Some(100));
    assert_eq!(restart.every_seconds, Some(3600.0));
    for (bad, key) in [
        ("    Frequency: 0", "Frequency"),
        ("    Wall Clock Interval: -1.0", "Wall Clock Interval"),
        ("    Frequncy: 10", "Frequncy"),
    ] {
        let text = base_with("  Solver:", &format!("  Restart:\n{bad}\n  Solver:"));
        let error = yaml(&text).unwrap_err().to_string();
        assert!(error.contains(&format!("Restart → {key}")), "{error}");
    }
}

#[test]
fn time_steps_list_sets_the_final_time() {
    let text = base_with(
        "    Final Time: 1.0\n    QuasiStatic:\n      Number of Load Steps: 2",
        "    QuasiStatic:\n      Time Steps: \"0.0 .25 .5 1.0 2.5\"",
    );
    let deck = yaml(&text).unwrap();
    let Integrator::QuasiStatic(q) = &deck.solvers[0].integrator else {
        panic!("QuasiStatic")
    };
    assert_eq!(
        q.load_steps,
        LoadSteps::Times(vec![0.0, 0.25, 0.5, 1.0, 2.5])
    );
    assert_eq!(deck.solvers[0].final_time, 2.5);
}

#[test]
fn node_set_single_integer_is_an_id_and_a_word_is_a_file() {
    // Peridigm's nodeSetStringToFileName: a single token that parses as a non-zero integer is
    // an id list; any other single token is a file name.
    let deck = yaml(BASE_YAML).unwrap();
    assert_eq!(
        deck.node_set("LEFT_NODE_SET").unwrap().source,
        NodeSetSource::Ids(vec![1])
    );
    let text = base_with("Left Node Set: \"1\"", "Left Node Set: \"left.txt\"");
    let deck = deck::parse_str(
        &text,
        deck::DeckFormat::Yaml,
        Path::new("/runs/bar/wave.yaml"),
    )
    .unwrap();
    assert_eq!(
        deck.node_set("Left Node Set").unwrap().source,
        NodeSetSource::File("/runs/bar/left.txt".into())
    );
}
