//! Bad decks: every error names the file, the key path and the line, and says what to do.
//!
//! Each test breaks the valid base deck (`deck_common::BASE_YAML`) in one place; the expected
//! line is the line of the test text where the offending key is written.

mod deck_common;

use deck_common::*;
use peridyn::io::deck::{self, DeckError};

#[test]
fn base_deck_is_valid() {
    let deck = yaml(BASE_YAML).expect("the base deck must load");
    assert_eq!(deck.materials.len(), 1);
    assert_eq!(deck.solvers.len(), 1);
}

#[test]
fn malformed_yaml_gives_parser_line_and_column() {
    // An unterminated double-quoted string: the scanner runs to the end of the file.
    let text = base_with("Material: \"Steel\"", "Material: \"Steel");
    let err = yaml(&text).unwrap_err();
    let message = err.to_string();
    assert!(
        matches!(err, DeckError::Syntax { format: "YAML", .. }),
        "{message}"
    );
    assert!(message.starts_with("wave.yaml:"), "{message}");
    assert!(message.contains("malformed YAML"), "{message}");

    // A tab used for indentation is reported exactly where it is.
    let text = base_with("      Density: 7800.0", "\tDensity: 7800.0");
    let err = yaml(&text).unwrap_err();
    let line = line_containing(&text, "\tDensity");
    assert!(
        matches!(err, DeckError::Syntax { line: l, .. } if l == line),
        "expected line {line}: {err}"
    );
    assert!(
        err.to_string().starts_with(&format!("wave.yaml:{line}:")),
        "{err}"
    );
}

#[test]
fn malformed_xml_gives_parser_line_and_column() {
    let text = "<ParameterList>\n  <ParameterList name=\"Materials\">\n    <Parameter name=\"Density\" type=\"double\" value=\"1.0\"/>\n  </ParameterLst>\n</ParameterList>\n";
    let err = xml(text).unwrap_err();
    let message = err.to_string();
    assert!(
        matches!(
            err,
            DeckError::Syntax {
                format: "XML",
                line: 4,
                ..
            }
        ),
        "{message}"
    );
    assert!(message.starts_with("wave.xml:4:"), "{message}");
    assert!(message.contains("malformed XML"), "{message}");
}

#[test]
fn unknown_key_suggests_the_closest_valid_key() {
    // A typo of a required key is reported as the typo, at its own line (not as "missing").
    let text = base_with("Density: 7800.0", "Densty: 7800.0");
    let line = line_containing(&text, "Densty");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Densty",
        &["unknown key; did you mean \"Density\"?"],
    );

    let text = base_with(
        "Density: 7800.0",
        "Density: 7800.0\n      Shear Modulous: 1.0",
    );
    let line = line_containing(&text, "Shear Modulous");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Shear Modulous",
        &["unknown key", "did you mean \"Shear Modulus\"?"],
    );
}

#[test]
fn misspelled_key_at_top_level_and_in_solver() {
    let text = base_with("  Blocks:", "  Blocs:");
    let line = line_containing(&text, "Blocs:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Blocs",
        &["did you mean \"Blocks\"?"],
    );

    let text = base_with(
        "Maximum Solver Iterations: 5",
        "Maximum Solver Iteration: 5",
    );
    let line = line_containing(&text, "Maximum Solver Iteration:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Solver → QuasiStatic → Maximum Solver Iteration",
        &["did you mean \"Maximum Solver Iterations\"?"],
    );
}

#[test]
fn key_of_another_material_model_is_a_warning_naming_it() {
    // Peridigm does not validate material lists, so decks carry keys of other models (issue:
    // "keys Peridigm accepts elsewhere without effect are warnings, not errors").
    let text = base_with(
        "Density: 7800.0",
        "Density: 7800.0\n      Yield Stress: 1.0e8\n      Hourglass Coefficient: 0.02",
    );
    let deck = yaml(&text).expect("a key of another model is accepted");
    for key in ["Yield Stress", "Hourglass Coefficient"] {
        let line = line_containing(&text, key);
        assert!(
            deck.warnings
                .iter()
                .any(|w| w.contains(&format!("Materials → Steel → {key}"))
                    && w.contains(&format!(":{line}:"))
                    && w.contains("no effect")),
            "{key}: {:?}",
            deck.warnings
        );
    }
}

#[test]
fn a_top_level_key_peridigm_reads_without_effect_is_a_warning() {
    let text = base_with(
        "Peridigm:\n",
        "Peridigm:\n  Enable Bond-Associated Hypoelastic Model: false\n",
    );
    let deck = yaml(&text).expect("the key is accepted");
    assert!(
        deck.warnings
            .iter()
            .any(|w| w.contains("Enable Bond-Associated Hypoelastic Model")
                && w.contains("no effect")),
        "{:?}",
        deck.warnings
    );
}

#[test]
fn missing_required_key_names_the_enclosing_list() {
    let text = base_with("      Density: 7800.0\n", "");
    let line = line_containing(&text, "    Steel:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Density",
        &["required key is missing", "add `Density`"],
    );
}

#[test]
fn string_where_a_number_is_needed() {
    let text = base_with("Density: 7800.0", "Density: \"heavy\"");
    let line = line_containing(&text, "Density:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Density",
        &["expected a number", "\"heavy\""],
    );

    // A quoted number is still a string (Teuchos typing); the message says how to fix it.
    let text = base_with("Density: 7800.0", "Density: \"7800.0\"");
    let message = error_message(yaml(&text));
    assert!(message.contains("without quotes"), "{message}");
}

#[test]
fn non_positive_density_horizon_and_lengths() {
    for (from, to, needle, path) in [
        (
            "Density: 7800.0",
            "Density: 0.0",
            "Density:",
            "Materials → Steel → Density",
        ),
        (
            "Density: 7800.0",
            "Density: -1.0",
            "Density:",
            "Materials → Steel → Density",
        ),
        (
            "Horizon: 2",
            "Horizon: -0.5",
            "Horizon:",
            "Blocks → Everything → Horizon",
        ),
        (
            "Horizon: 2",
            "Horizon: 0",
            "Horizon:",
            "Blocks → Everything → Horizon",
        ),
        (
            "Y Length: 1.0",
            "Y Length: 0.0",
            "Y Length:",
            "Discretization → TensorProduct3DMeshGenerator → Y Length",
        ),
        (
            "Bulk Modulus: 130.0e9",
            "Bulk Modulus: -130.0e9",
            "Bulk Modulus:",
            "Materials → Steel → Bulk Modulus",
        ),
    ] {
        let text = base_with(from, to);
        let line = line_containing(&text, needle);
        let message = error_message(yaml(&text));
        assert_error(
            &message,
            YAML_NAME,
            line,
            path,
            &["must be a positive number"],
        );
    }
}

#[test]
fn contact_radii_must_be_positive() {
    let contact = "  Contact:\n    Search Radius: -1.0\n    Search Frequency: 10\n  Solver:";
    let text = base_with("  Solver:", contact);
    let line = line_containing(&text, "Search Radius");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Contact → Search Radius",
        &["must be a positive number"],
    );

    let contact = "  Contact:\n    Search Radius: 1.0\n    Search Frequency: 10\n    Models:\n      Soft:\n        Contact Model: \"Short Range Force\"\n        Contact Radius: 0.0\n        Spring Constant: 1.0\n  Solver:";
    let text = base_with("  Solver:", contact);
    let line = line_containing(&text, "Contact Radius");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Contact → Models → Soft → Contact Radius",
        &["must be a positive number"],
    );
}

#[test]
fn poisson_ratio_must_lie_in_the_open_interval() {
    let text = base_with("Shear Modulus: 78.0e9", "Poisson's Ratio: 0.5");
    let line = line_containing(&text, "Poisson's Ratio");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Poisson's Ratio",
        &["between -1 and 0.5"],
    );
}

#[test]
fn three_elastic_constants_are_rejected() {
    let text = base_with(
        "Shear Modulus: 78.0e9",
        "Shear Modulus: 78.0e9\n      Young's Modulus: 200.0e9",
    );
    let line = line_containing(&text, "Young's Modulus");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Young's Modulus",
        &["exactly two of", "found 3"],
    );
}

#[test]
fn one_elastic_constant_is_rejected() {
    let text = base_with("      Shear Modulus: 78.0e9\n", "");
    let line = line_containing(&text, "    Steel:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel",
        &["exactly two of", "found 1"],
    );
}

#[test]
fn block_naming_a_missing_material() {
    let text = base_with("Material: \"Steel\"", "Material: \"Stee\"");
    let line = line_containing(&text, "Material: \"Stee\"");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Blocks → Everything → Material",
        &["no material named \"Stee\"", "did you mean \"Steel\"?"],
    );
}

#[test]
fn block_naming_a_missing_damage_model() {
    let text = base_with(
        "Material: \"Steel\"",
        "Material: \"Steel\"\n      Damage Model: \"Brittle\"",
    );
    let line = line_containing(&text, "Damage Model");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Blocks → Everything → Damage Model",
        &["no damage model named \"Brittle\""],
    );
}

#[test]
fn unknown_boundary_condition_type() {
    let text = base_with(
        "Type: \"Prescribed Displacement\"",
        "Type: \"Prescribed Displacment\"",
    );
    let line = line_containing(&text, "Displacment");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Boundary Conditions → Push Left → Type",
        &[
            "unknown boundary condition type",
            "did you mean \"Prescribed Displacement\"?",
        ],
    );
}

#[test]
fn boundary_condition_type_is_normalised_like_peridigm() {
    // Peridigm upper-cases and turns spaces into underscores before comparing.
    let text = base_with(
        "Type: \"Prescribed Displacement\"",
        "Type: \"prescribed_displacement\"",
    );
    let deck = yaml(&text).expect("normalised BC types are accepted");
    assert_eq!(
        deck.boundary_conditions.conditions[0].kind,
        deck::BoundaryConditionKind::PrescribedDisplacement
    );
}

#[test]
fn bad_coordinate() {
    let text = base_with("Coordinate: \"x\"", "Coordinate: \"w\"");
    let line = line_containing(&text, "Coordinate: \"w\"");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Boundary Conditions → Push Left → Coordinate",
        &["\"x\", \"y\" or \"z\""],
    );
}

#[test]
fn node_set_ids_must_be_integers_from_one() {
    let text = base_with("Left Node Set: \"1\"", "Left Node Set: \"1 2.5\"");
    let line = line_containing(&text, "Left Node Set:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Boundary Conditions → Left Node Set",
        &["\"2.5\" is not an integer"],
    );

    let text = base_with("Left Node Set: \"1\"", "Left Node Set: \"-1 1\"");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Boundary Conditions → Left Node Set",
        &["node id -1", "starts at 1"],
    );
}

#[test]
fn node_id_zero_marks_a_legacy_zero_based_deck() {
    // Peridigm's early decks numbered points from 0 (ElementVariableOutput.xml); a 0 in any
    // list switches the whole deck to 0-based ids, with a warning naming the key.
    let text = base_with("Left Node Set: \"1\"", "Left Node Set: \"0 1\"");
    let deck = yaml(&text).expect("a 0-based deck loads");
    assert!(deck.boundary_conditions.zero_based_ids);
    assert!(deck
        .warnings
        .iter()
        .any(|w| w.contains("Left Node Set") && w.contains("0-based")));
}

#[test]
fn boundary_condition_on_an_undefined_node_set_of_a_quickgrid() {
    // PdQuickGrid has no mesh node sets, so the name must be defined in the deck.
    let text = base_with("Node Set: \"Left Node Set\"", "Node Set: \"Left Node St\"");
    let line = line_containing(&text, "Left Node St\"");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Boundary Conditions → Push Left → Node Set",
        &["did you mean \"Left Node Set\"?"],
    );
}

#[test]
fn solver_without_integrator() {
    let text = base_with(
        "    QuasiStatic:\n      Number of Load Steps: 2\n      Maximum Solver Iterations: 5\n",
        "",
    );
    let line = line_containing(&text, "  Solver:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Solver",
        &["no time integrator", "Verlet"],
    );
}

#[test]
fn solver_with_two_integrators() {
    let text = base_with(
        "    QuasiStatic:",
        "    Verlet:\n      Safety Factor: 0.8\n    QuasiStatic:",
    );
    let line = line_containing(&text, "    QuasiStatic:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Solver → QuasiStatic",
        &["exactly one integrator"],
    );
}

#[test]
fn output_frequency_must_be_an_integer() {
    let text = base_with("Output Frequency: 1", "Output Frequency: 2.5");
    let line = line_containing(&text, "Output Frequency");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Output → Output Frequency",
        &["expected an integer"],
    );
}

#[test]
fn bool_written_as_a_string() {
    let text = base_with("Displacement: true", "Displacement: \"true\"");
    let line = line_containing(&text, "Displacement:");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Output → Output Variables → Displacement",
        &["expected true or false", "without quotes"],
    );
}

#[test]
fn final_time_must_follow_initial_time() {
    let text = base_with("Final Time: 1.0", "Final Time: 0.0");
    let line = line_containing(&text, "Final Time");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Solver → Final Time",
        &["must be larger than Initial Time"],
    );
}

#[test]
fn xml_string_where_a_number_is_needed() {
    let text = TWIN_XML.replace(
        "<Parameter name=\"Density\" type=\"double\" value=\"7800.0\"/>",
        "<Parameter name=\"Density\" type=\"string\" value=\"7800.0\"/>",
    );
    let line = line_containing(&text, "name=\"Density\"");
    let message = error_message(xml(&text));
    assert_error(
        &message,
        XML_NAME,
        line,
        "Materials → Steel → Density",
        &["expected a number", "type=\"double\""],
    );
}

#[test]
fn xml_unknown_key_and_bad_double() {
    let base = TWIN_XML;
    let text = base.replace("name=\"Density\"", "name=\"Densty\"");
    let line = line_containing(&text, "Densty");
    let message = error_message(xml(&text));
    assert_error(
        &message,
        XML_NAME,
        line,
        "Materials → Steel → Densty",
        &["unknown key; did you mean \"Density\"?"],
    );

    let text = base.replace("value=\"7800.0\"", "value=\"7800.0.0\"");
    let line = line_containing(&text, "7800.0.0");
    let message = error_message(xml(&text));
    assert_error(
        &message,
        XML_NAME,
        line,
        "Materials → Steel → Density",
        &["not a valid number"],
    );
}

#[test]
fn unknown_extension_and_missing_file() {
    let err = deck::load(std::path::Path::new("deck.peridigm")).unwrap_err();
    assert!(matches!(err, DeckError::UnknownFormat { .. }), "{err}");
    assert!(err.to_string().contains(".yaml, .yml or .xml"), "{err}");

    let err = deck::load(std::path::Path::new("/nonexistent/dir/deck.yaml")).unwrap_err();
    assert!(matches!(err, DeckError::Io { .. }), "{err}");
    assert!(
        err.to_string().starts_with("/nonexistent/dir/deck.yaml:"),
        "{err}"
    );
}

#[test]
fn horizon_in_a_material_is_rejected() {
    let text = base_with("Density: 7800.0", "Density: 7800.0\n      Horizon: 1.0");
    let line = line_containing(&text, "      Horizon: 1.0");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Horizon",
        &["set `Horizon` in the block"],
    );
}

#[test]
fn duplicate_key_with_different_values() {
    let text = base_with("Density: 7800.0", "Density: 7800.0\n      Density: 7900.0");
    let line = line_containing(&text, "Density: 7900.0");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Density",
        &["written twice", "first on line"],
    );
}

#[test]
fn microplastic_needs_a_positive_yield_stretch_and_refuses_thermal_expansion() {
    let microplastic = "Material Model: \"Microplastic Bond Based\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n";
    let text = base_with(
        "Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n",
        &format!("{microplastic}      Yield Stretch: 0.002\n"),
    );
    yaml(&text).expect("a microplastic material with its yield stretch loads");

    let text = base_with(
        "Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n",
        microplastic,
    );
    let message = error_message(yaml(&text));
    assert!(message.contains("Yield Stretch"), "{message}");

    let text = base_with(
        "Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n",
        &format!("{microplastic}      Yield Stretch: -0.002\n"),
    );
    let line = line_containing(&text, "Yield Stretch");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Yield Stretch",
        &["-0.002"],
    );

    let text = base_with(
        "Material Model: \"Elastic\"\n      Density: 7800.0\n      Bulk Modulus: 130.0e9\n      Shear Modulus: 78.0e9\n",
        &format!("{microplastic}      Yield Stretch: 0.002\n      Thermal Expansion Coefficient: 1.0e-5\n"),
    );
    let line = line_containing(&text, "Thermal Expansion Coefficient");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Materials → Steel → Thermal Expansion Coefficient",
        &["Microplastic Bond Based", "no thermal strain"],
    );
}

#[test]
fn surface_correction_names_its_choices_and_elastic_partial_volume_loads_as_elastic() {
    let text = base_with(
        "Horizon: 2\n",
        "Horizon: 2\n      Surface Correction: \"Force Normalization\"\n",
    );
    let deck = yaml(&text).expect("a block with a surface correction loads");
    assert_eq!(
        deck.blocks[0].surface_correction.as_deref(),
        Some("Force Normalization")
    );

    let text = base_with(
        "Horizon: 2\n",
        "Horizon: 2\n      Surface Correction: \"Normalize\"\n",
    );
    let line = line_containing(&text, "Surface Correction");
    let message = error_message(yaml(&text));
    assert_error(
        &message,
        YAML_NAME,
        line,
        "Blocks → Everything → Surface Correction",
        &["Force Normalization"],
    );

    // Peridigm's `Elastic Partial Volume` is the LPS of `Elastic` (its partial volumes are
    // the block's quadrature rule), with the same keys.
    let text = base_with(
        "Material Model: \"Elastic\"",
        "Material Model: \"Elastic Partial Volume\"",
    );
    let deck = yaml(&text).expect("Elastic Partial Volume loads");
    assert_eq!(deck.materials[0].model.deck_name(), "Elastic");
}
