//! How a SNES is set up and described: Newton with its line search or nonlinear CG with its
//! preconditioner ([`set_method`]), the description the log and `peridyn check` print, and
//! PETSc's names of its converged reasons.

use std::ffi::CString;

use super::super::linear::{resolved_types, PETSC_DEFAULT_REAL};
use super::super::options::DeckOptions;
use super::super::runtime::{check, owned_string, PetscError};
use super::super::sys;
use super::{NcgBeta, NcgSettings};

/// Sets `snes`'s method: `newtonls` with the `bt` line search (`basic` without
/// `line_search`), or SNESNCG with the `cp` line search (the step where F·d = 0 along the
/// direction d, by secant steps: for F the gradient of an energy, the exact step of linear
/// CG, which is what NOX's `NonlinearCG` line search computes from one directional
/// derivative) and, when preconditioned, its nonlinear preconditioner (see
/// [`NcgPreconditioner`]), whose SNES is returned for the caller to give it F and the
/// tangent. The options database, read later, overrides all of it.
pub(super) unsafe fn set_method(
    snes: sys::SNES,
    ncg: Option<&NcgSettings>,
    line_search: bool,
) -> Result<Option<sys::SNES>, PetscError> {
    let mut search: sys::SNESLineSearch = std::ptr::null_mut();
    let Some(ncg) = ncg else {
        check(sys::SNESSetType(snes, c"newtonls".as_ptr()))?;
        check(sys::SNESGetLineSearch(snes, &mut search))?;
        let kind = if line_search { c"bt" } else { c"basic" };
        check(sys::SNESLineSearchSetType(search, kind.as_ptr()))?;
        return Ok(None);
    };
    check(sys::SNESSetType(snes, c"ncg".as_ptr()))?;
    check(sys::SNESNCGSetType(
        snes,
        match ncg.beta {
            NcgBeta::FletcherReeves => sys::SNESNCGType_SNES_NCG_FR,
            NcgBeta::PolakRibiere => sys::SNESNCGType_SNES_NCG_PRP,
        },
    ))?;
    check(sys::SNESGetLineSearch(snes, &mut search))?;
    check(sys::SNESLineSearchSetType(search, c"cp".as_ptr()))?;
    let Some(preconditioner) = &ncg.preconditioner else {
        return Ok(None);
    };
    let mut npc: sys::SNES = std::ptr::null_mut();
    check(sys::SNESGetNPC(snes, &mut npc))?;
    check(sys::SNESSetType(npc, c"newtonls".as_ptr()))?;
    let mut npc_search: sys::SNESLineSearch = std::ptr::null_mut();
    check(sys::SNESGetLineSearch(npc, &mut npc_search))?;
    check(sys::SNESLineSearchSetType(npc_search, c"basic".as_ptr()))?;
    // The Krylov solve stops at its iteration count, which PETSc calls a failure.
    check(sys::SNESSetMaxLinearSolveFailures(npc, sys::PetscInt::MAX))?;
    let lag =
        sys::PetscInt::try_from(preconditioner.jacobian_lag.max(1)).unwrap_or(sys::PetscInt::MAX);
    check(sys::SNESSetLagJacobian(npc, lag))?;
    check(sys::SNESSetLagJacobianPersists(
        npc,
        sys::PetscBool_PETSC_TRUE,
    ))?;
    let mut ksp: sys::KSP = std::ptr::null_mut();
    let mut pc: sys::PC = std::ptr::null_mut();
    let name = |text: &str| {
        CString::new(text).map_err(|_| PetscError {
            code: -1,
            message: format!("the type name {text:?} contains a NUL character"),
        })
    };
    let ksp_type = name(&preconditioner.ksp)?;
    let pc_type = name(&preconditioner.pc)?;
    check(sys::SNESGetKSP(npc, &mut ksp))?;
    check(sys::KSPSetType(ksp, ksp_type.as_ptr()))?;
    check(sys::KSPGetPC(ksp, &mut pc))?;
    check(sys::PCSetType(pc, pc_type.as_ptr()))?;
    check(sys::KSPSetTolerances(
        ksp,
        0.0,
        PETSC_DEFAULT_REAL,
        PETSC_DEFAULT_REAL,
        sys::PetscInt::try_from(preconditioner.iterations.max(1)).unwrap_or(sys::PetscInt::MAX),
    ))?;
    Ok(Some(npc))
}

/// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>` of a configured SNES;
/// for nonlinear CG `PETSc SNES ncg <β> (line search <type>), restarted every <n>
/// iterations, preconditioned by one newtonls step: KSP <type> + PC <type>, <k> iterations`.
pub(super) fn describe(
    snes: sys::SNES,
    ncg: Option<&NcgSettings>,
    options: &DeckOptions,
) -> Result<String, PetscError> {
    let Some(ncg) = ncg else {
        return describe_newton(snes);
    };
    let (snes_type, line_search_type) = types(snes)?;
    if snes_type != "ncg" {
        return describe_newton(snes);
    }
    // PETSc 3.18 has no getter of the β formula: the deck's option, else the deck's key.
    let beta = options
        .options
        .iter()
        .find(|(name, _)| name == "snes_ncg_type")
        .and_then(|(_, value)| value.clone())
        .unwrap_or_else(|| ncg.beta.name().to_string());
    let mut text = format!(
        "PETSc SNES ncg {beta} (line search {line_search_type}), restarted every {} iterations",
        ncg.restart_every
    );
    match &ncg.preconditioner {
        None => text.push_str(", unpreconditioned"),
        Some(preconditioner) => {
            let mut npc: sys::SNES = std::ptr::null_mut();
            let mut ksp: sys::KSP = std::ptr::null_mut();
            // SAFETY: `snes` is live and has its preconditioner (set by `set_method`).
            unsafe {
                check(sys::SNESGetNPC(snes, &mut npc))?;
                check(sys::SNESGetKSP(npc, &mut ksp))?;
            }
            text.push_str(&format!(
                ", preconditioned by one newtonls step: {}, {} iterations",
                resolved_types(ksp)?.trim_start_matches("PETSc "),
                preconditioner.iterations
            ));
            if preconditioner.jacobian_lag > 1 {
                text.push_str(&format!(
                    ", tangent rebuilt every {} applications",
                    preconditioner.jacobian_lag
                ));
            }
        }
    }
    Ok(text)
}

/// `PETSc SNES <type> (line search <type>), KSP <type> + PC <type>` of a configured SNES.
fn describe_newton(snes: sys::SNES) -> Result<String, PetscError> {
    let (snes_type, line_search_type) = types(snes)?;
    let mut ksp: sys::KSP = std::ptr::null_mut();
    // SAFETY: `snes` is live.
    unsafe { check(sys::SNESGetKSP(snes, &mut ksp))? };
    let linear = resolved_types(ksp)?;
    Ok(format!(
        "PETSc SNES {snes_type} (line search {line_search_type}), {}",
        linear.trim_start_matches("PETSc ")
    ))
}

/// The type names of a configured SNES and of its line search.
fn types(snes: sys::SNES) -> Result<(String, String), PetscError> {
    let mut snes_type: sys::SNESType = std::ptr::null();
    let mut line_search: sys::SNESLineSearch = std::ptr::null_mut();
    let mut line_search_type: sys::SNESLineSearchType = std::ptr::null();
    // SAFETY: `snes` is live; the names belong to it.
    unsafe {
        check(sys::SNESGetType(snes, &mut snes_type))?;
        check(sys::SNESGetLineSearch(snes, &mut line_search))?;
        check(sys::SNESLineSearchGetType(
            line_search,
            &mut line_search_type,
        ))?;
    }
    Ok((owned_string(snes_type), owned_string(line_search_type)))
}

/// PETSc's name of a SNES converged reason.
pub(super) fn reason_name(reason: sys::SNESConvergedReason) -> String {
    match reason {
        sys::SNESConvergedReason_SNES_CONVERGED_FNORM_ABS => "SNES_CONVERGED_FNORM_ABS".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_MAX_IT => "SNES_DIVERGED_MAX_IT".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_FNORM_NAN => "SNES_DIVERGED_FNORM_NAN".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_LINE_SEARCH => "SNES_DIVERGED_LINE_SEARCH".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_LINEAR_SOLVE => "SNES_DIVERGED_LINEAR_SOLVE".into(),
        sys::SNESConvergedReason_SNES_DIVERGED_FUNCTION_COUNT => {
            "SNES_DIVERGED_FUNCTION_COUNT".into()
        }
        other => format!("SNES converged reason {other}"),
    }
}
