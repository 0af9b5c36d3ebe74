//! Where the body is now: the mutable fields of a run (run order, one entry per point).

/// Kinematic state and forces. Fields exist only when the run needs them (the external force
/// only with a body force).
#[derive(Debug, Clone, Default)]
pub struct State {
    /// Time t (s).
    pub time: f64,
    /// Displacement u (length).
    pub displacement: Vec<[f64; 3]>,
    /// Velocity v (length/s).
    pub velocity: Vec<[f64; 3]>,
    /// Acceleration a = (f_int + b)/ρ (length/s²).
    pub acceleration: Vec<[f64; 3]>,
    /// Internal force density f_int (force/length³).
    pub force_density: Vec<[f64; 3]>,
    /// External (body) force density b (force/length³), when the deck has a body force.
    pub external_force_density: Option<Vec<[f64; 3]>>,
    /// Current positions Y = X + u (length), refreshed before every force evaluation.
    pub current_position: Vec<[f64; 3]>,
}

impl State {
    /// A body at rest in the reference configuration.
    pub fn at_rest(reference: &[[f64; 3]], time: f64, body_force: bool) -> Self {
        let n = reference.len();
        Self {
            time,
            displacement: vec![[0.0; 3]; n],
            velocity: vec![[0.0; 3]; n],
            acceleration: vec![[0.0; 3]; n],
            force_density: vec![[0.0; 3]; n],
            external_force_density: body_force.then(|| vec![[0.0; 3]; n]),
            current_position: reference.to_vec(),
        }
    }

    /// Y = X + u.
    pub fn update_current_position(&mut self, reference: &[[f64; 3]]) {
        for ((y, x), u) in self
            .current_position
            .iter_mut()
            .zip(reference)
            .zip(&self.displacement)
        {
            *y = [x[0] + u[0], x[1] + u[1], x[2] + u[2]];
        }
    }
}
