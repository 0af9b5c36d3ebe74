//! Shared helpers for the deck tests: a small valid deck and line lookup in test text.

#![allow(dead_code)]

use std::path::Path;

use peridyn::io::deck::{parse_str, Deck, DeckError, DeckFormat};

/// A small, valid YAML deck (three points in a row, quasi-static compression) that the error
/// tests break in one place each.
pub const BASE_YAML: &str = r#"Peridigm:
  Discretization:
    Type: "PdQuickGrid"
    NeighborhoodType: "Spherical"
    TensorProduct3DMeshGenerator:
      X Origin: 0.0
      Y Origin: 0.0
      Z Origin: 0.0
      X Length: 3.0
      Y Length: 1.0
      Z Length: 1.0
      Number Points X: 3
      Number Points Y: 1
      Number Points Z: 1
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Bulk Modulus: 130.0e9
      Shear Modulus: 78.0e9
  Blocks:
    Everything:
      Block Names: "block_1"
      Material: "Steel"
      Horizon: 2
  Boundary Conditions:
    Left Node Set: "1"
    Right Node Set: "3"
    Push Left:
      Type: "Prescribed Displacement"
      Node Set: "Left Node Set"
      Coordinate: "x"
      Value: "if(t < 0.5)\{ value = 0.01*t; \} else\{ value = 0.005; \}"
    Hold Right:
      Type: "Prescribed Displacement"
      Node Set: "Right Node Set"
      Coordinate: "x"
      Value: 0.0
  Solver:
    Initial Time: 0.0
    Final Time: 1.0
    QuasiStatic:
      Number of Load Steps: 2
      Maximum Solver Iterations: 5
  Output:
    Output Filename: "bar"
    Output Frequency: 1
    Output Variables:
      Displacement: true
      Force: true
"#;

/// The name the test decks pretend to come from.
pub const YAML_NAME: &str = "wave.yaml";
/// The name the XML test decks pretend to come from.
pub const XML_NAME: &str = "wave.xml";

/// Parses YAML text as if read from `wave.yaml` in the current directory.
pub fn yaml(text: &str) -> Result<Deck, DeckError> {
    parse_str(text, DeckFormat::Yaml, Path::new(YAML_NAME))
}

/// Parses XML text as if read from `wave.xml`.
pub fn xml(text: &str) -> Result<Deck, DeckError> {
    parse_str(text, DeckFormat::Xml, Path::new(XML_NAME))
}

/// The base deck with one substring replaced (panics if `from` is not in the deck, so a test
/// cannot silently test the unmodified deck).
pub fn base_with(from: &str, to: &str) -> String {
    assert!(BASE_YAML.contains(from), "`{from}` is not in the base deck");
    BASE_YAML.replacen(from, to, 1)
}

/// 1-based line of the first line of `text` containing `needle` (the line a message must name).
pub fn line_containing(text: &str, needle: &str) -> usize {
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("`{needle}` not in text"))
        + 1
}

/// Expects an error and returns its message.
pub fn error_message(result: Result<Deck, DeckError>) -> String {
    match result {
        Ok(_) => panic!("the deck was accepted but should have been rejected"),
        Err(e) => e.to_string(),
    }
}

/// Asserts that `message` starts with `file:line: path:` and contains every piece of `parts`.
pub fn assert_error(message: &str, file: &str, line: usize, path: &str, parts: &[&str]) {
    let prefix = format!("{file}:{line}: {path}: ");
    assert!(
        message.starts_with(&prefix),
        "expected the message to start with `{prefix}`, got `{message}`"
    );
    for part in parts {
        assert!(message.contains(part), "expected `{part}` in `{message}`");
    }
}

/// A richer YAML deck; [`TWIN_XML`] says exactly the same in Teuchos XML.
pub const TWIN_YAML: &str = r#"# Twin of TWIN_XML: both must give equal decks.
Peridigm:
  Verbose: false
  Discretization:
    Type: "Exodus"
    Input Mesh File: "mesh/plate.g"
    Influence Function: "Parabolic Decay"
    Omit Bonds Between Blocks: "All"
    Bond Filters:
      Crack:
        Type: "Rectangular_Plane"
        Normal_X: 0.0
        Normal_Y: 1.0
        Normal_Z: 0.0
        Lower_Left_Corner_X: -1.0
        Lower_Left_Corner_Y: 0.0
        Lower_Left_Corner_Z: -1.0
        Bottom_Unit_Vector_X: 1.0
        Bottom_Unit_Vector_Y: 0.0
        Bottom_Unit_Vector_Z: 0.0
        Bottom_Length: 2
        Side_Length: 2.0
  Materials:
    Steel:
      Material Model: "Elastic"
      Density: 7800.0
      Young's Modulus: 200.0e9
      Poisson's Ratio: 0.25
      Thermal Expansion Coefficient: 1.2e-5
    Soft:
      Material Model: "Elastic Plastic"
      Density: 2700.0
      Bulk Modulus: 70.0e9
      Shear Modulus: 26.0e9
      Yield Stress: 2.5e8
  Damage Models:
    Brittle:
      Damage Model: "Critical Stretch"
      Critical Stretch: 0.001
  Blocks:
    Plate:
      Block Names: "block_1 block_2"
      Material: "Steel"
      Damage Model: "Brittle"
      Horizon: 2
    Impactor:
      Block Names: "block_3"
      Material: "Soft"
      Damage Model: "None"
      Horizon: "0.5 + 0.1*x"
  Contact:
    Search Radius: 3.0
    Search Frequency: 100
    Models:
      Spring:
        Contact Model: "Short Range Force"
        Contact Radius: 0.4
        Spring Constant: 1.0e12
        Friction Coefficient: 0.1
    Interactions:
      General Contact:
        Contact Model: "Spring"
  Boundary Conditions:
    Min X Node Set: "1 4 7 10"
    Max X Node Set: "nodes/max_x.txt"
    Create Node Set For Rank Deficient Nodes: true
    Pull:
      Type: "Prescribed Displacement"
      Node Set: "Max X Node Set"
      Coordinate: "y"
      Value: "if(t < 0.5)\{ value = 0.01*t; \} else\{ value = 0.005; \}"
    Fix:
      Type: "Prescribed Displacement"
      Node Set: "nodelist_1"
      Coordinate: "z"
      Value: 0.0
    Heat:
      Type: "Initial Temperature"
      Node Set: "min x node set"
      Value: "100.0"
  Solver1:
    Initial Time: 0.0
    Final Time: 1.0
    Peridigm Preconditioner: "Block 3x3"
    NOXQuasiStatic:
      Nonlinear Solver: "Line Search Based"
      Number of Load Steps: 4
      Max Solver Iterations: 20
      Relative Tolerance: 1.0e-8
      Direction:
        Method: "Newton"
        Newton:
          Linear Solver:
            Jacobian Operator: "Matrix-Free"
            Preconditioner: "User Defined"
            Max Iterations: 200
      Line Search:
        Method: "Polynomial"
  Solver2:
    Initial Time: 1.0
    Final Time: 1.5
    Verlet:
      Safety Factor: 0.8
  Compute Class Parameters:
    Reaction:
      Compute Class: "Block_Data"
      Calculation Type: "Sum"
      Block: "block_1"
      Variable: "Force"
      Output Label: "Reaction_Force"
    Gauge:
      Compute Class: "Nearest_Point_Data"
      X: 0.0
      Y: 1.0
      Z: 0
      Variable: "Displacement"
      Output Label: "Gauge_Displacement"
      Verbose: false
  Output1:
    Output File Type: "ExodusII"
    Output Format: "BINARY"
    Output Filename: "plate"
    Output Frequency: 10
    Output Variables:
      Displacement: true
      Damage: true
      Reaction_Force: true
      Gauge_Displacement: true
      Velocity: false
"#;

/// The XML twin of [`TWIN_YAML`].
pub const TWIN_XML: &str = r#"<ParameterList name="Peridigm">
  <!-- Twin of TWIN_YAML: both must give equal decks. -->
  <Parameter name="Verbose" type="bool" value="false"/>
  <ParameterList name="Discretization">
    <Parameter name="Type" type="string" value="Exodus"/>
    <Parameter name="Input Mesh File" type="string" value="mesh/plate.g"/>
    <Parameter name="Influence Function" type="string" value="Parabolic Decay"/>
    <Parameter name="Omit Bonds Between Blocks" type="string" value="All"/>
    <ParameterList name="Bond Filters">
      <ParameterList name="Crack">
        <Parameter name="Type" type="string" value="Rectangular_Plane"/>
        <Parameter name="Normal_X" type="double" value="0.0"/>
        <Parameter name="Normal_Y" type="double" value="1.0"/>
        <Parameter name="Normal_Z" type="double" value="0.0"/>
        <Parameter name="Lower_Left_Corner_X" type="double" value="-1.0"/>
        <Parameter name="Lower_Left_Corner_Y" type="double" value="0.0"/>
        <Parameter name="Lower_Left_Corner_Z" type="double" value="-1.0"/>
        <Parameter name="Bottom_Unit_Vector_X" type="double" value="1.0"/>
        <Parameter name="Bottom_Unit_Vector_Y" type="double" value="0.0"/>
        <Parameter name="Bottom_Unit_Vector_Z" type="double" value="0.0"/>
        <Parameter name="Bottom_Length" type="int" value="2"/>
        <Parameter name="Side_Length" type="double" value="2.0"/>
      </ParameterList>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Materials">
    <ParameterList name="Steel">
      <Parameter name="Material Model" type="string" value="Elastic"/>
      <Parameter name="Density" type="double" value="7800.0"/>
      <Parameter name="Young's Modulus" type="double" value="200.0e9"/>
      <Parameter name="Poisson's Ratio" type="double" value="0.25"/>
      <Parameter name="Thermal Expansion Coefficient" type="double" value="1.2e-5"/>
    </ParameterList>
    <ParameterList name="Soft">
      <Parameter name="Material Model" type="string" value="Elastic Plastic"/>
      <Parameter name="Density" type="double" value="2700.0"/>
      <Parameter name="Bulk Modulus" type="double" value="70.0e9"/>
      <Parameter name="Shear Modulus" type="double" value="26.0e9"/>
      <Parameter name="Yield Stress" type="double" value="2.5e8"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Damage Models">
    <ParameterList name="Brittle">
      <Parameter name="Damage Model" type="string" value="Critical Stretch"/>
      <Parameter name="Critical Stretch" type="double" value="0.001"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Blocks">
    <ParameterList name="Plate">
      <Parameter name="Block Names" type="string" value="block_1 block_2"/>
      <Parameter name="Material" type="string" value="Steel"/>
      <Parameter name="Damage Model" type="string" value="Brittle"/>
      <Parameter name="Horizon" type="double" value="2.0"/>
    </ParameterList>
    <ParameterList name="Impactor">
      <Parameter name="Block Names" type="string" value="block_3"/>
      <Parameter name="Material" type="string" value="Soft"/>
      <Parameter name="Damage Model" type="string" value="None"/>
      <Parameter name="Horizon" type="string" value="0.5 + 0.1*x"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Contact">
    <Parameter name="Search Radius" type="double" value="3.0"/>
    <Parameter name="Search Frequency" type="int" value="100"/>
    <ParameterList name="Models">
      <ParameterList name="Spring">
        <Parameter name="Contact Model" type="string" value="Short Range Force"/>
        <Parameter name="Contact Radius" type="double" value="0.4"/>
        <Parameter name="Spring Constant" type="double" value="1.0e12"/>
        <Parameter name="Friction Coefficient" type="double" value="0.1"/>
      </ParameterList>
    </ParameterList>
    <ParameterList name="Interactions">
      <ParameterList name="General Contact">
        <Parameter name="Contact Model" type="string" value="Spring"/>
      </ParameterList>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Boundary Conditions">
    <Parameter name="Min X Node Set" type="string" value="1 4 7 10"/>
    <Parameter name="Max X Node Set" type="string" value="nodes/max_x.txt"/>
    <Parameter name="Create Node Set For Rank Deficient Nodes" type="bool" value="true"/>
    <ParameterList name="Pull">
      <Parameter name="Type" type="string" value="Prescribed Displacement"/>
      <Parameter name="Node Set" type="string" value="Max X Node Set"/>
      <Parameter name="Coordinate" type="string" value="y"/>
      <Parameter name="Value" type="string" value="if(t &lt; 0.5){ value = 0.01*t; } else{ value = 0.005; }"/>
    </ParameterList>
    <ParameterList name="Fix">
      <Parameter name="Type" type="string" value="Prescribed Displacement"/>
      <Parameter name="Node Set" type="string" value="nodelist_1"/>
      <Parameter name="Coordinate" type="string" value="z"/>
      <Parameter name="Value" type="double" value="0.0"/>
    </ParameterList>
    <ParameterList name="Heat">
      <Parameter name="Type" type="string" value="Initial Temperature"/>
      <Parameter name="Node Set" type="string" value="min x node set"/>
      <Parameter name="Value" type="string" value="100.0"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Solver1">
    <Parameter name="Initial Time" type="double" value="0.0"/>
    <Parameter name="Final Time" type="double" value="1.0"/>
    <Parameter name="Peridigm Preconditioner" type="string" value="Block 3x3"/>
    <ParameterList name="NOXQuasiStatic">
      <Parameter name="Nonlinear Solver" type="string" value="Line Search Based"/>
      <Parameter name="Number of Load Steps" type="int" value="4"/>
      <Parameter name="Max Solver Iterations" type="int" value="20"/>
      <Parameter name="Relative Tolerance" type="double" value="1.0e-8"/>
      <ParameterList name="Direction">
        <Parameter name="Method" type="string" value="Newton"/>
        <ParameterList name="Newton">
          <ParameterList name="Linear Solver">
            <Parameter name="Jacobian Operator" type="string" value="Matrix-Free"/>
            <Parameter name="Preconditioner" type="string" value="User Defined"/>
            <Parameter name="Max Iterations" type="int" value="200"/>
          </ParameterList>
        </ParameterList>
      </ParameterList>
      <ParameterList name="Line Search">
        <Parameter name="Method" type="string" value="Polynomial"/>
      </ParameterList>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Solver2">
    <Parameter name="Initial Time" type="double" value="1.0"/>
    <Parameter name="Final Time" type="double" value="1.5"/>
    <ParameterList name="Verlet">
      <Parameter name="Safety Factor" type="double" value="0.8"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Compute Class Parameters">
    <ParameterList name="Reaction">
      <Parameter name="Compute Class" type="string" value="Block_Data"/>
      <Parameter name="Calculation Type" type="string" value="Sum"/>
      <Parameter name="Block" type="string" value="block_1"/>
      <Parameter name="Variable" type="string" value="Force"/>
      <Parameter name="Output Label" type="string" value="Reaction_Force"/>
    </ParameterList>
    <ParameterList name="Gauge">
      <Parameter name="Compute Class" type="string" value="Nearest_Point_Data"/>
      <Parameter name="X" type="double" value="0.0"/>
      <Parameter name="Y" type="double" value="1.0"/>
      <Parameter name="Z" type="double" value="0.0"/>
      <Parameter name="Variable" type="string" value="Displacement"/>
      <Parameter name="Output Label" type="string" value="Gauge_Displacement"/>
      <Parameter name="Verbose" type="bool" value="false"/>
    </ParameterList>
  </ParameterList>
  <ParameterList name="Output1">
    <Parameter name="Output File Type" type="string" value="ExodusII"/>
    <Parameter name="Output Format" type="string" value="BINARY"/>
    <Parameter name="Output Filename" type="string" value="plate"/>
    <Parameter name="Output Frequency" type="int" value="10"/>
    <ParameterList name="Output Variables">
      <Parameter name="Displacement" type="bool" value="true"/>
      <Parameter name="Damage" type="bool" value="true"/>
      <Parameter name="Reaction_Force" type="bool" value="true"/>
      <Parameter name="Gauge_Displacement" type="bool" value="true"/>
      <Parameter name="Velocity" type="bool" value="false"/>
    </ParameterList>
  </ParameterList>
</ParameterList>
"#;
