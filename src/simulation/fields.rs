//! What a running simulation can write: point fields, energies and compute-class globals.

pub use crate::compute::{prepare_compute_classes, PreparedComputeClass};
use crate::io::deck::CalculationType;
use crate::io::output::FieldSource;
use crate::model::Model;
use crate::physics::Physics;
use crate::state::State;
use std::borrow::Cow;

/// A read-only view of a simulation for the output writer.
pub struct Fields<'a> {
    /// The model.
    pub model: &'a Model,
    /// Materials and damage.
    pub physics: &'a Physics,
    /// Current state.
    pub state: &'a State,
    /// Prepared compute classes.
    pub compute_classes: &'a [PreparedComputeClass],
    /// Newton iterations of the last implicit step (`Nonlinear_Solver_Iterations`), if any.
    pub nonlinear_iterations: Option<f64>,
}

impl<'a> Fields<'a> {
    /// A view of a simulation's current state.
    pub fn new(
        model: &'a Model,
        physics: &'a Physics,
        state: &'a State,
        compute_classes: &'a [PreparedComputeClass],
    ) -> Self {
        Self {
            model,
            physics,
            state,
            compute_classes,
            nonlinear_iterations: None,
        }
    }

    fn stored_energy_density(&self) -> Vec<f64> {
        let mut w = vec![0.0; self.model.points.len()];
        self.physics.stored_energy_density(
            &self.model.bonds,
            &self.model.points,
            &self.state.current_position,
            self.state.bond_damage(),
            &self.state.history,
            &mut w,
        );
        w
    }

    /// A 3×3 history field of the materials (row-major per point); zero where no block keeps
    /// it.
    fn history_tensor(&self, name: &str) -> Vec<[f64; 9]> {
        match self.state.history.field(name) {
            Some(field) => {
                let values = field.trial();
                values
                    .chunks_exact(9)
                    .map(|t| std::array::from_fn(|k| t[k]))
                    .collect()
            }
            None => vec![[0.0; 9]; self.model.points.len()],
        }
    }

    fn hourglass_force_density(&self) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; self.model.points.len()];
        self.physics.hourglass_force_density(
            &self.model.bonds,
            &self.model.points,
            &self.state.current_position,
            self.state.bond_damage(),
            &self.state.history,
            &mut out,
        );
        out
    }
}

impl FieldSource for Fields<'_> {
    fn vector(&self, name: &str) -> Option<Cow<'_, [[f64; 3]]>> {
        let points = &self.model.points;
        let state = self.state;
        Some(match name {
            "Displacement" => Cow::Borrowed(&state.displacement),
            "Velocity" => Cow::Borrowed(&state.velocity),
            "Acceleration" => Cow::Borrowed(&state.acceleration),
            "Force_Density" => Cow::Borrowed(&state.force_density),
            "Coordinates" => Cow::Borrowed(&state.current_position),
            "Model_Coordinates" => Cow::Borrowed(&points.position),
            "External_Force_Density" => match &state.external_force_density {
                Some(b) => Cow::Borrowed(b),
                None => Cow::Owned(vec![[0.0; 3]; points.len()]),
            },
            "Force" => Cow::Owned(
                state
                    .force_density
                    .iter()
                    .zip(&points.volume)
                    .map(|(f, v)| [f[0] * v, f[1] * v, f[2] * v])
                    .collect(),
            ),
            // Zero without a Contact section (no contact acts).
            "Contact_Force_Density" => match &state.contact {
                Some(contact) => Cow::Borrowed(contact.force_density()),
                None => Cow::Owned(vec![[0.0; 3]; points.len()]),
            },
            "Contact_Force" => Cow::Owned(match &state.contact {
                Some(contact) => contact
                    .force_density()
                    .iter()
                    .zip(&points.volume)
                    .map(|(f, v)| [f[0] * v, f[1] * v, f[2] * v])
                    .collect(),
                None => vec![[0.0; 3]; points.len()],
            }),
            "Hourglass_Force_Density" => Cow::Owned(self.hourglass_force_density()),
            "Linear_Momentum" => Cow::Owned(
                (0..points.len())
                    .map(|i| {
                        let m = self.physics.density[i] * points.volume[i];
                        let v = state.velocity[i];
                        [m * v[0], m * v[1], m * v[2]]
                    })
                    .collect(),
            ),
            "Angular_Momentum" => Cow::Owned(
                (0..points.len())
                    .map(|i| {
                        // L = y × m v about the origin, y the current position.
                        let m = self.physics.density[i] * points.volume[i];
                        let (y, v) = (state.current_position[i], state.velocity[i]);
                        [
                            m * (y[1] * v[2] - y[2] * v[1]),
                            m * (y[2] * v[0] - y[0] * v[2]),
                            m * (y[0] * v[1] - y[1] * v[0]),
                        ]
                    })
                    .collect(),
            ),
            _ => return None,
        })
    }

    fn scalar(&self, name: &str) -> Option<Cow<'_, [f64]>> {
        let points = &self.model.points;
        let n = points.len();
        Some(Cow::Owned(match name {
            "Volume" => return Some(Cow::Borrowed(&points.volume)),
            "Horizon" => return Some(Cow::Borrowed(&self.model.horizon)),
            "Radius" => (0..n).map(|i| points.radius(i)).collect(),
            "Element_Id" => points
                .original_id
                .iter()
                .map(|&id| id as f64 + 1.0)
                .collect(),
            "Block_Id" => points
                .block
                .iter()
                .map(|&b| self.model.blocks[b as usize].info.id as f64)
                .collect(),
            "Proc_Num" => vec![0.0; n],
            "Number_Of_Neighbors" => (0..n)
                .map(|i| self.model.bonds.family_size(i) as f64)
                .collect(),
            // Σ_j w_ij over the family with the block's quadrature volumes (Σ_j V_j under the
            // full-volume rule), as Peridigm's partial-volume build writes it.
            "Neighborhood_Volume" => self
                .physics
                .neighborhood_volume(&self.model.bonds, &self.model.points),
            "Equivalent_Plastic_Strain" => {
                match self
                    .state
                    .history
                    .field(crate::material::correspondence_fields::EQUIVALENT_PLASTIC_STRAIN)
                {
                    Some(field) => return Some(Cow::Borrowed(field.trial())),
                    None => vec![0.0; n],
                }
            }
            // Zero without temperature conditions (no point temperature is kept then).
            "Temperature" => match self.state.history.thermal() {
                Some(thermal) => return Some(Cow::Borrowed(&thermal.temperature)),
                None => vec![0.0; n],
            },
            "Temperature_Change" => match self.state.history.thermal() {
                Some(thermal) => return Some(Cow::Borrowed(&thermal.change)),
                None => vec![0.0; n],
            },
            "Lambda" => match self
                .state
                .history
                .field(crate::material::elastic_plastic_fields::LAMBDA)
            {
                Some(field) => return Some(Cow::Borrowed(field.trial())),
                None => vec![0.0; n],
            },
            // σ_vm = √(3/2 s:s), s the deviator of the Cauchy stress.
            "Von_Mises_Stress" => self
                .history_tensor(crate::material::correspondence_fields::CAUCHY_STRESS)
                .iter()
                .map(von_mises)
                .collect(),
            "Dilatation" => self
                .physics
                .coefficients
                .iter()
                .map(|c| c.dilatation)
                .collect(),
            "Weighted_Volume" => {
                let mut m = vec![0.0; n];
                for block in &self.physics.blocks {
                    if let Some(values) = block.material.weighted_volume() {
                        for (&p, &value) in block.material.points().iter().zip(values) {
                            m[p as usize] = value;
                        }
                    }
                }
                m
            }
            "Damage" => {
                let mut d = vec![0.0; n];
                self.physics
                    .point_damage(&self.model.bonds, self.state.bond_damage(), &mut d);
                d
            }
            "Kinetic_Energy" => (0..n)
                .map(|i| {
                    let v = self.state.velocity[i];
                    0.5 * self.physics.density[i]
                        * points.volume[i]
                        * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                })
                .collect(),
            "Stored_Elastic_Energy_Density" => self.stored_energy_density(),
            "Stored_Elastic_Energy" => self
                .stored_energy_density()
                .iter()
                .zip(&points.volume)
                .map(|(w, v)| w * v)
                .collect(),
            // A field a material keeps itself (e.g. `Pals`' Lagrange multipliers); zero on the
            // points of other blocks, and everywhere when no block's model keeps it.
            _ => {
                let declared = crate::material::MATERIALS
                    .iter()
                    .any(|entry| entry.declaration.outputs.contains(&name));
                let mut values = vec![0.0; n];
                let mut found = false;
                for block in &self.physics.blocks {
                    if let Some(block_values) = block.material.point_output(name) {
                        found = true;
                        for (&p, value) in block.material.points().iter().zip(block_values) {
                            values[p as usize] = value;
                        }
                    }
                }
                if !(found || declared) {
                    return None;
                }
                values
            }
        }))
    }

    fn tensor(&self, name: &str) -> Option<Cow<'_, [[f64; 9]]>> {
        match name {
            "Deformation_Gradient" => Some(Cow::Owned(crate::compute::deformation_gradient(
                &self.model.bonds,
                &self.model.points.position,
                &self.state.current_position,
                self.physics.bond_volumes(&self.model.points),
                self.state.bond_damage(),
            ))),
            "Partial_Stress" => {
                let mut stress = vec![[0.0; 9]; self.model.points.len()];
                self.physics.partial_stress(
                    &self.model.bonds,
                    &self.model.points,
                    &self.state.current_position,
                    self.state.bond_damage(),
                    &self.state.history,
                    &mut stress,
                );
                Some(Cow::Owned(stress))
            }
            "Shape_Tensor_Inverse" => Some(Cow::Owned(crate::compute::shape_tensor_inverse(
                &self.model.bonds,
                &self.model.points.position,
                self.physics.bond_volumes(&self.model.points),
                self.state.bond_damage(),
            ))),
            "Cauchy_Stress" => Some(Cow::Owned(
                self.history_tensor(crate::material::correspondence_fields::CAUCHY_STRESS),
            )),
            "Unrotated_Cauchy_Stress" => Some(Cow::Owned(
                self.history_tensor(crate::material::correspondence_fields::UNROTATED_STRESS),
            )),
            _ => None,
        }
    }

    fn global(&self, name: &str) -> Option<f64> {
        global_value(self, self.compute_classes, self.nonlinear_iterations, name)
    }

    fn global_vector(&self, name: &str) -> Option<[f64; 3]> {
        global_vector_value(self, self.compute_classes, name)
    }
}

/// √(3/2 s:s) of a row-major stress tensor, s its deviator.
fn von_mises(sigma: &[f64; 9]) -> f64 {
    let mean = (sigma[0] + sigma[4] + sigma[8]) / 3.0;
    let mut squared = 0.0;
    for (k, value) in sigma.iter().enumerate() {
        let deviatoric = if k % 4 == 0 { value - mean } else { *value };
        squared += deviatoric * deviatoric;
    }
    (1.5 * squared).sqrt()
}

fn reduce(values: impl Iterator<Item = f64>, calculation: CalculationType) -> f64 {
    match calculation {
        CalculationType::Sum => values.sum(),
        CalculationType::Minimum => values.fold(f64::INFINITY, f64::min),
        CalculationType::Maximum => values.fold(f64::NEG_INFINITY, f64::max),
    }
}

/// A global output from the point fields of `source` (run order): energies summed over the
/// points in run order, compute classes reduced over their points in the order listed. Shared
/// by the serial [`Fields`] and the gathered fields of a distributed run, so both add the same
/// numbers in the same order.
pub(crate) fn global_value(
    source: &dyn FieldSource,
    classes: &[PreparedComputeClass],
    nonlinear_iterations: Option<f64>,
    name: &str,
) -> Option<f64> {
    match name {
        "Global_Kinetic_Energy" => Some(source.scalar("Kinetic_Energy")?.iter().sum()),
        "Global_Stored_Elastic_Energy" => {
            Some(source.scalar("Stored_Elastic_Energy")?.iter().sum())
        }
        // Zero for explicit solvers, as Peridigm writes it.
        "Nonlinear_Solver_Iterations" => Some(nonlinear_iterations.unwrap_or(0.0)),
        _ => {
            let class = classes.iter().find(|c| c.label == name)?;
            let values = source.scalar(&class.variable)?;
            let selected = class.points.iter().map(|&p| values[p as usize]);
            Some(match class.calculation {
                Some(calculation) => reduce(selected, calculation),
                None => selected.into_iter().next().unwrap_or(0.0),
            })
        }
    }
}

/// A global vector output from the point fields of `source` (see [`global_value`]).
pub(crate) fn global_vector_value(
    source: &dyn FieldSource,
    classes: &[PreparedComputeClass],
    name: &str,
) -> Option<[f64; 3]> {
    if let Some(field) = match name {
        "Global_Linear_Momentum" => Some("Linear_Momentum"),
        "Global_Angular_Momentum" => Some("Angular_Momentum"),
        _ => None,
    } {
        let momentum = source.vector(field)?;
        return Some([0, 1, 2].map(|k| momentum.iter().map(|m| m[k]).sum()));
    }
    let class = classes.iter().find(|c| c.label == name)?;
    let values = source.vector(&class.variable)?;
    Some([0, 1, 2].map(|k| {
        let selected = class.points.iter().map(|&p| values[p as usize][k]);
        match class.calculation {
            Some(calculation) => reduce(selected, calculation),
            None => selected.into_iter().next().unwrap_or(0.0),
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::deck::{parse_str, DeckFormat};

    #[test]
    fn momenta_of_a_spinning_pair() {
        // Two unit-mass points (ρ = 1, V = 1) at x = ±1 moving at ±1 along y: linear momentum 0,
        // angular momentum about the origin L_z = Σ m (x v_y − y v_x) = 1·1 + (−1)(−1) = 2.
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("pair.txt"), "-1 0 0 1 1.0\n1 0 0 1 1.0\n").unwrap();
        let text = r#"Peridigm:
  Discretization: {Type: "Text File", Input Mesh File: "pair.txt"}
  Materials:
    M: {Material Model: "Elastic Bond Based", Density: 1.0, Bulk Modulus: 1.0}
  Blocks:
    B: {Block Names: "block_1", Material: "M", Horizon: 0.5}
  Boundary Conditions:
    Left Node Set: "1"
    Right Node Set: "2"
    Down: {Type: "Initial Velocity", Node Set: "Left Node Set", Coordinate: "y", Value: "-1.0"}
    Up: {Type: "Initial Velocity", Node Set: "Right Node Set", Coordinate: "y", Value: "1.0"}
  Solver:
    Final Time: 1.0
    Verlet: {Fixed dt: 0.1}
"#;
        let deck = parse_str(text, DeckFormat::Yaml, &dir.path().join("deck.yaml")).unwrap();
        let model = crate::setup::build(&deck).unwrap();
        let physics = crate::setup::build_physics(&deck, &model).unwrap();
        let mut state = State::at_rest(&model.points.position, 0.0, false);
        model
            .boundary
            .apply_initial(
                &model.points.position,
                0.0,
                &mut state.displacement,
                &mut state.velocity,
            )
            .unwrap();
        let fields = Fields::new(&model, &physics, &state, &[]);
        assert_eq!(
            fields.global_vector("Global_Linear_Momentum"),
            Some([0.0, 0.0, 0.0])
        );
        assert_eq!(
            fields.global_vector("Global_Angular_Momentum"),
            Some([0.0, 0.0, 2.0])
        );
        // Kinetic energy ½ Σ m v² = 1.
        assert_eq!(fields.global("Global_Kinetic_Energy"), Some(1.0));
    }
}
