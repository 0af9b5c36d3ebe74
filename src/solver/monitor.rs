//! The stability monitor of explicit runs: energy in the body against energy supplied.
//!
//! For a stable velocity-Verlet run the kinetic plus stored elastic energy stays within the
//! initial energy plus the work done by body forces and prescribed displacements (damage only
//! removes energy). An unstable step size makes the energy grow geometrically, without any work
//! to account for it. The monitor stops the run when the kinetic energy exceeds
//! [`EnergyMonitor::GROWTH_LIMIT`] times the energy budget, or when a non-finite value appears.
//! The kinetic energy is a lower bound of the body's energy, so checking it every step costs
//! one pass over the points and never fires on a stable run.

/// Why a run was stopped.
#[derive(Debug, Clone, PartialEq)]
pub struct Instability {
    /// Step number (1-based) at which the blow-up was detected.
    pub step: u64,
    /// Time at that step.
    pub time: f64,
    /// Kinetic energy at that step (may be non-finite).
    pub kinetic_energy: f64,
    /// The energy budget it was compared with.
    pub budget: f64,
}

/// Tracks the energy budget of an explicit run.
#[derive(Debug, Clone)]
pub struct EnergyMonitor {
    initial_energy: f64,
    supplied_work: f64,
    floor: f64,
}

impl EnergyMonitor {
    /// The kinetic energy may exceed the budget by this factor before the run is stopped.
    /// A stable run stays at or below 1 (up to the time-discretisation error); an unstable one
    /// passes any fixed factor within a few tens of steps of growth.
    pub const GROWTH_LIMIT: f64 = 100.0;

    /// Starts a budget with the body's initial kinetic + stored energy. `floor` is the energy
    /// below which changes count as round-off (e.g. the strain energy of the body at a strain
    /// of 1e-6), so that an unloaded body at rest never trips the monitor.
    pub fn new(initial_energy: f64, floor: f64) -> Self {
        Self {
            initial_energy,
            supplied_work: 0.0,
            floor: floor.max(f64::MIN_POSITIVE),
        }
    }

    /// Initial energy and the work supplied so far (a restart file keeps them).
    pub fn energies(&self) -> [f64; 2] {
        [self.initial_energy, self.supplied_work]
    }

    /// Continues a monitor whose [`EnergyMonitor::energies`] were `energies` (a run resumed
    /// from a restart file; the floor stays this monitor's).
    pub fn restore(&mut self, energies: [f64; 2]) {
        [self.initial_energy, self.supplied_work] = energies;
    }

    /// Adds the magnitude of work done on the body in one step (body forces, constraints).
    pub fn add_work(&mut self, work: f64) {
        if work.is_finite() {
            self.supplied_work += work.abs();
        }
    }

    /// The energy the body may hold: initial energy + supplied work (at least the floor).
    pub fn budget(&self) -> f64 {
        (self.initial_energy + self.supplied_work).max(self.floor)
    }

    /// Checks the kinetic energy after step `step` at time `time`.
    pub fn check(&self, step: u64, time: f64, kinetic_energy: f64) -> Result<(), Instability> {
        let budget = self.budget();
        if kinetic_energy.is_finite() && kinetic_energy <= Self::GROWTH_LIMIT * budget {
            return Ok(());
        }
        Err(Instability {
            step,
            time,
            kinetic_energy,
            budget,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fires_on_growth_and_non_finite_values_only() {
        let mut monitor = EnergyMonitor::new(1.0, 1e-9);
        monitor.add_work(-0.5);
        // Budget = 1 + |−0.5| = 1.5; the limit is 100 × 1.5 = 150.
        assert!(monitor.check(1, 0.1, 149.0).is_ok());
        let error = monitor.check(2, 0.2, 151.0).unwrap_err();
        assert_eq!(error.step, 2);
        assert_eq!(error.budget, 1.5);
        assert!(monitor.check(3, 0.3, f64::NAN).is_err());
        assert!(monitor.check(3, 0.3, f64::INFINITY).is_err());
    }

    #[test]
    fn an_unloaded_body_is_judged_against_the_floor() {
        let monitor = EnergyMonitor::new(0.0, 1e-6);
        assert!(monitor.check(1, 0.0, 1e-20).is_ok());
        assert!(monitor.check(1, 0.0, 1e-3).is_err());
    }
}
