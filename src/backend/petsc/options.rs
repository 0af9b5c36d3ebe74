//! A solver list's `PETSc Options` in PETSc's options database, under the list's prefix.
//!
//! The deck's options (`-ksp_type gmres -pc_type gamg`) are inserted with the prefix of their
//! solver list pushed (`solver_`, so PETSc stores `-solver_ksp_type gmres`), and the KSP or
//! SNES of that list carries the same prefix: its `SetFromOptions` reads them after peridyn's
//! own settings, so they override the deck's other keys. They stay in the database while the
//! solver lives and are cleared when it is destroyed. An option PETSc never looked up (a typo,
//! or one for a component that is not there) is reported once, after the first solve, as a
//! warning naming the deck key.

use std::ffi::CString;

use super::runtime::{check, PetscError, Turn};
use super::sys;

/// The `PETSc Options` of one solver list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeckOptions {
    /// The options prefix, from the solver list's name (`Solver1` → `solver1_`).
    pub prefix: String,
    /// (name without `-`, value) pairs, in deck order.
    pub options: Vec<(String, Option<String>)>,
    /// The deck key the options came from, for messages (`Solver → PETSc Options`).
    pub key: String,
}

impl DeckOptions {
    /// The options of solver list `list`.
    pub fn new(list: &str, options: Vec<(String, Option<String>)>) -> Self {
        Self {
            prefix: prefix_of(list),
            options,
            key: format!("{list} → PETSc Options"),
        }
    }

    /// The prefix as a C string.
    pub(super) fn c_prefix(&self) -> CString {
        CString::new(self.prefix.clone()).expect("the prefix is letters, digits and _")
    }

    /// True when the deck gives option `name` (without `-` or prefix).
    pub fn gives(&self, name: &str) -> bool {
        self.options.iter().any(|(n, _)| n == name)
    }

    /// Puts the options in PETSc's database under the prefix; `defaults` (name, value) are
    /// peridyn's settings that only the options database can carry (sub-preconditioner
    /// settings), inserted first so the deck's own options override them.
    pub(super) fn insert(
        &self,
        _turn: &Turn,
        defaults: &[(&str, String)],
    ) -> Result<(), PetscError> {
        let mut text = String::new();
        for (name, value) in defaults {
            if !self.gives(name) {
                text.push_str(&format!(" -{name} {value}"));
            }
        }
        for (name, value) in &self.options {
            text.push_str(&format!(" -{name}"));
            if let Some(value) = value {
                text.push_str(&format!(" {value}"));
            }
        }
        if text.is_empty() {
            return Ok(());
        }
        let text = CString::new(text).map_err(|_| PetscError {
            code: -1,
            message: format!("{}: an option contains a NUL character", self.key),
        })?;
        let prefix = self.c_prefix();
        // SAFETY: the global database (NULL), NUL-terminated strings that outlive the calls;
        // the prefix is popped whatever the insertion returned.
        unsafe {
            check(sys::PetscOptionsPrefixPush(
                std::ptr::null_mut(),
                prefix.as_ptr(),
            ))?;
            let inserted = check(sys::PetscOptionsInsertString(
                std::ptr::null_mut(),
                text.as_ptr(),
            ));
            check(sys::PetscOptionsPrefixPop(std::ptr::null_mut()))?;
            inserted
        }
        .map_err(|e| PetscError {
            code: e.code,
            message: format!("{}: {}", self.key, e.message),
        })
    }

    /// The deck's options PETSc has not looked up, as `-name` (no prefix).
    pub(super) fn unused(&self, _turn: &Turn) -> Vec<String> {
        self.options
            .iter()
            .filter(|(name, _)| {
                // PETSc stores names without the `-`, and PetscOptionsUsed compares with them.
                let full = CString::new(format!("{}{name}", self.prefix))
                    .expect("names have no NUL (checked by the deck reader)");
                let mut used = sys::PetscBool_PETSC_FALSE;
                // SAFETY: a query of the global database with a NUL-terminated name.
                let code = unsafe {
                    sys::PetscOptionsUsed(std::ptr::null_mut(), full.as_ptr(), &mut used)
                };
                check(code).is_ok() && used == sys::PetscBool_PETSC_FALSE
            })
            .map(|(name, _)| format!("-{name}"))
            .collect()
    }

    /// Prints the warning about unused options, if any.
    pub(super) fn warn_unused(&self, turn: &Turn) {
        let unused = self.unused(turn);
        if !unused.is_empty() {
            eprintln!(
                "Warning: {}: PETSc did not use {} (check the spelling with -help, and that the component they configure is in use)",
                self.key,
                unused.join(" ")
            );
        }
    }

    /// Removes the deck's options (and `defaults`) from the database.
    pub(super) fn clear(&self, _turn: &Turn, defaults: &[(&str, String)]) {
        let names = self
            .options
            .iter()
            .map(|(n, _)| n.as_str())
            .chain(defaults.iter().map(|(n, _)| *n));
        for name in names {
            let full = self.full_name(name);
            // SAFETY: as in `unused`; clearing an option that is not set is not an error.
            unsafe { sys::PetscOptionsClearValue(std::ptr::null_mut(), full.as_ptr()) };
        }
    }

    /// `-<prefix><name>` as PETSc stores it.
    fn full_name(&self, name: &str) -> CString {
        CString::new(format!("-{}{name}", self.prefix))
            .expect("names have no NUL (checked by the deck reader)")
    }
}

/// PETSc's options prefix of a solver list: its name in lower case, every character other than
/// a letter or digit replaced by `_`, then `_` (`Solver` → `solver_`).
pub fn prefix_of(list: &str) -> String {
    let mut prefix: String = list
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    if !prefix.starts_with(|c: char| c.is_ascii_alphabetic()) {
        prefix.insert(0, 's');
    }
    prefix.push('_');
    prefix
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_prefix_is_the_list_name_in_lower_case() {
        assert_eq!(prefix_of("Solver"), "solver_");
        assert_eq!(prefix_of("Solver 2"), "solver_2_");
        assert_eq!(prefix_of("2nd"), "s2nd_");
    }
}
