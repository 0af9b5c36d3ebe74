//! The checks of a deck against the model built from it that `peridyn check` and `peridyn
//! run` both make before anything runs, so that what one accepts the other runs and what one
//! refuses the other refuses alike (exit code 2, file, key path and line).

use crate::compute::prepare_compute_classes;
use crate::io::deck::{Deck, DeckError};
use crate::model::Model;
use crate::solver::{step_count, MAX_STEPS};

use super::report::{critical_time_step, requested_variables};

/// Every check, for a model whose families are built (one process).
pub fn validate(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    validate_points(deck, model)?;
    validate_time_steps(deck, model)?;
    super::one_way_bonds::refuse_one_way_bonds(deck, model)?;
    super::bondless::refuse_motionless(deck, model)?;
    validate_petsc_options(deck, model)
}

/// Every `Backend: "PETSc"` list's solver is set up once with its `PETSc Options`, so an
/// option PETSc refuses (an unknown KSP type, a malformed value) is an input error naming the
/// key before anything runs.
#[cfg(feature = "petsc")]
fn validate_petsc_options(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    use crate::backend::petsc::list;
    for list in super::solvers::solver_lists(deck) {
        let Some(solve) = list.integrator.solve() else {
            continue;
        };
        let on_petsc = matches!(
            solve.linear.backend,
            crate::backend::settings::LinearBackend::Petsc { .. }
        );
        let name = list.settings.name.as_str();
        if let (true, Err(e)) = (on_petsc, list::ncg(solve)) {
            let mut path = vec![name];
            path.extend(e.path.iter().copied());
            return Err(deck.error_at(&path, e.message));
        }
        if let Some(Err(message)) = list::resolve(solve, 3 * model.points.len()) {
            return Err(deck.error_at(
                &[name, "PETSc Options"],
                format!("PETSc refused the solver settings: {message}; fix or remove the option (PETSc's -help lists them)"),
            ));
        }
    }
    Ok(())
}

#[cfg(not(feature = "petsc"))]
fn validate_petsc_options(_deck: &Deck, _model: &Model) -> Result<(), DeckError> {
    Ok(())
}

/// The checks that need points and node sets only (a distributed run's global model has no
/// families; its driver makes the time-step checks on the families it finds).
pub fn validate_points(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    validate_restart(deck)?;
    for entry in &deck.blocks {
        super::surface_correction::block_correction(deck, entry)?;
    }
    for output in &deck.outputs {
        requested_variables(deck, output)?;
    }
    if let Err(message) = prepare_compute_classes(&deck.compute_classes, model) {
        let class = deck
            .compute_classes
            .iter()
            .find(|c| message.contains(&format!("\"{}\"", c.name)));
        return Err(match class {
            Some(class) => deck.error_at(&["Compute Class Parameters", &class.name], message),
            None => deck.error_at(&["Compute Class Parameters"], message),
        });
    }
    Ok(())
}

/// A deck that asks for restart files needs a build with HDF5 (feature `hdf5`).
fn validate_restart(deck: &Deck) -> Result<(), DeckError> {
    if deck.restart.is_some() && !cfg!(feature = "hdf5") {
        return Err(deck.error_at(
            &["Restart"],
            "restart files are written with HDF5, and this peridyn was built without the `hdf5` \
             feature: install the HDF5 library (`apt-get install libhdf5-dev` on Debian and \
             Ubuntu) and rebuild with `cargo build --release --features hdf5`, or remove the \
             Restart entry to run without restart files",
        ));
    }
    Ok(())
}

/// Every list that advances by a time step (`Verlet`, `Implicit`) must have one and a step
/// count within [`MAX_STEPS`].
fn validate_time_steps(deck: &Deck, model: &Model) -> Result<(), DeckError> {
    // Computed once, and only if a list needs it (one pass over the bonds).
    let mut estimate: Option<Option<f64>> = None;
    for list in super::solvers::solver_lists(deck) {
        let Some(step) = list.integrator.time_step() else {
            continue;
        };
        let solver = &list.settings;
        let span = solver.span();
        let step_key = step.deck_key();
        let stable_estimate = match step.needs_estimate() {
            true => *estimate.get_or_insert_with(|| critical_time_step(deck, model)),
            false => None,
        };
        let time_step = step
            .with_estimate(stable_estimate)
            .ok_or_else(|| no_neighbours(deck, model, &solver.name))?;
        if step_count(span, time_step).is_some() {
            continue;
        }
        // The time step is at fault when it is no normal positive double (a Safety Factor only
        // when the stable estimate is one), or when the span runs at the stable estimate.
        let stable = (*estimate.get_or_insert_with(|| critical_time_step(deck, model)))
            .filter(|stable| stable.is_normal());
        let step_at_fault = (!time_step.is_normal()
            && (step_key == "Fixed dt" || stable.is_some()))
            || stable.is_some_and(|stable| step_count(span, stable).is_some());
        let message = format!(
            "solver \"{}\": {span:e} s at a time step of {time_step:e} s is not a step count peridyn can run (more than {MAX_STEPS:e} steps, or a zero time step); ",
            solver.name
        );
        let list = list.integrator.name();
        let error = match stable {
            Some(stable) if step_at_fault => deck.error_at(
                &[&solver.name, list, step_key],
                format!(
                    "{message}the time step is at fault: Peridigm's stable estimate for this body is {stable:.3e} s, which gives {} steps; give a \"{step_key}\" that makes a time step near it",
                    (span / stable).floor()
                ),
            ),
            _ if step_at_fault => deck.error_at(
                &[&solver.name, list, step_key],
                format!("{message}the time step is at fault: give a larger \"{step_key}\""),
            ),
            _ => deck.error_at(
                &[&solver.name, "Final Time"],
                format!("{message}check Final Time, Initial Time and the time step"),
            ),
        };
        return Err(error);
    }
    Ok(())
}

/// The error for a `Verlet` list without `Fixed dt` on a body where no point has a neighbour.
fn no_neighbours(deck: &Deck, model: &Model, solver: &str) -> DeckError {
    let Some(block) = model.blocks.first() else {
        return deck.error_at(&["Blocks"], "no block has a point");
    };
    let name = &deck.blocks[block.deck_block].name;
    deck.error_at(
        &["Blocks", name, "Horizon"],
        format!(
            "no point has a neighbour within its horizon, so solver \"{solver}\" has no stable time step: the horizon is smaller than the point spacing; make it about 3 spacings (or give the Verlet list a \"Fixed dt\")"
        ),
    )
}
