//! Build script: nothing to do unless a backend feature is enabled.
//!
//! With feature `trilinos` it compiles the cxx bridges `src/backend/trilinos/{ffi,nox_ffi}.rs`
//! and the shims `cpp/src/trilinos_{linear,nox}.cpp` with `cxx_build`, against the Trilinos and MPI found by
//! [`trilinos::discover`].
//!
//! With feature `petsc` it generates the C bindings `$OUT_DIR/petsc_bindings.rs` of the PETSc
//! functions `src/backend/petsc/sys.rs` calls ([`petsc::FUNCTIONS`]) with bindgen, against the
//! PETSc found by [`petsc::discover`].

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    #[cfg(feature = "trilinos")]
    trilinos::build();
    #[cfg(feature = "petsc")]
    petsc::build();
}

#[cfg(feature = "petsc")]
mod petsc {
    use std::path::PathBuf;

    /// Every PETSc function the backend calls: the allow-list of the bindings, so a PETSc
    /// header's other declarations (and their types) stay out.
    pub const FUNCTIONS: &[&str] = &[
        "PetscInitializeNoArguments",
        "PetscInitialized",
        "PetscFinalize",
        "PetscFinalized",
        "PetscPushErrorHandler",
        "PetscPopErrorHandler",
        "PetscOptionsInsertString",
        "PetscOptionsPrefixPush",
        "PetscOptionsPrefixPop",
        "PetscOptionsUsed",
        "PetscOptionsClearValue",
        "PetscOptionsHasName",
        "PetscObjectGetType",
        "VecCreateSeqWithArray",
        "VecCreateSeq",
        "VecPlaceArray",
        "VecResetArray",
        "VecGetArrayRead",
        "VecRestoreArrayRead",
        "VecGetArray",
        "VecRestoreArray",
        "VecGetLocalSize",
        "VecDestroy",
        "MatCreateSeqAIJWithArrays",
        "MatDestroy",
        "MatSetNearNullSpace",
        "MatSetBlockSize",
        "MatNullSpaceCreate",
        "MatNullSpaceDestroy",
        "MatAssemblyBegin",
        "MatAssemblyEnd",
        "MatSeqAIJGetArray",
        "MatSeqAIJRestoreArray",
        "KSPCreate",
        "KSPDestroy",
        "KSPSetType",
        "KSPGetType",
        "KSPGetPC",
        "KSPSetOperators",
        "KSPSetTolerances",
        "KSPGMRESSetRestart",
        "KSPSetInitialGuessNonzero",
        "KSPSetOptionsPrefix",
        "KSPSetFromOptions",
        "KSPSetUp",
        "KSPSolve",
        "KSPGetIterationNumber",
        "KSPGetConvergedReason",
        "KSPGetResidualNorm",
        "KSPSetNormType",
        "PCSetType",
        "PCGetType",
        "PCFactorSetMatSolverType",
        "SNESCreate",
        "SNESDestroy",
        "SNESSetType",
        "SNESGetType",
        "SNESGetKSP",
        "SNESGetLineSearch",
        "SNESLineSearchSetType",
        "SNESLineSearchGetType",
        "SNESSetFunction",
        "SNESSetJacobian",
        "SNESSetTolerances",
        "SNESSetConvergenceTest",
        "SNESSetOptionsPrefix",
        "SNESSetFromOptions",
        "SNESSolve",
        "SNESGetIterationNumber",
        "SNESGetLinearSolveIterations",
        "SNESGetConvergedReason",
        "SNESSetFunctionDomainError",
        "SNESSetUseMatrixFree",
        "SNESSetMaxLinearSolveFailures",
        "SNESSetUp",
        "SNESGetFunction",
        "SNESGetJacobian",
        "SNESGetNPC",
        "SNESNCGSetType",
        "SNESSetLagJacobian",
        "SNESSetLagJacobianPersists",
        "MatMFFDSetFunction",
        "MatCreateMPIAIJWithArrays",
        "MatSetValues",
        "MatMult",
        "VecCreateMPI",
        "VecCreateMPIWithArray",
        "VecDuplicate",
        "VecNorm",
        "VecAYPX",
        "AOCreateMapping",
        "AOApplicationToPetsc",
        "AODestroy",
    ];

    /// Include and link directories of PETSc and MPI.
    struct Found {
        include_dirs: Vec<PathBuf>,
    }

    pub fn build() {
        println!("cargo:rerun-if-changed=src/backend/petsc/sys.rs");
        for var in [
            "PETSC_DIR",
            "PETSC_ARCH",
            "PKG_CONFIG_PATH",
            "LIBCLANG_PATH",
        ] {
            println!("cargo:rerun-if-env-changed={var}");
        }
        let found = discover();
        let mut builder = bindgen::Builder::default()
            .header_contents(
                "peridyn_petsc.h",
                "#include <petscsnes.h>\n#include <petscao.h>\n",
            )
            .allowlist_recursively(true)
            // rsmpi's `MPI_Comm` is the one the rest of the program holds: the same type, so
            // its communicators pass straight through.
            .blocklist_type("MPI_Comm|ompi_communicator_t")
            .raw_line("pub use mpi::ffi::MPI_Comm;")
            // PETSc's `typedef struct _p_Vec *Vec` would shadow `std::vec::Vec`.
            .parse_callbacks(Box::new(RenameVec))
            .layout_tests(false)
            .generate_comments(false);
        for function in FUNCTIONS {
            builder = builder.allowlist_function(function);
        }
        for dir in &found.include_dirs {
            builder = builder.clang_arg(format!("-I{}", dir.display()));
        }
        let bindings = builder.generate().unwrap_or_else(|e| {
            panic!(
                "feature `petsc`: bindgen could not read PETSc's headers ({e}); install libpetsc-real-dev and libclang-dev \
                 (see .ci/petsc.sh), or set PETSC_DIR/PETSC_ARCH to your PETSc build; with several libclang versions \
                 installed set LIBCLANG_PATH to the one matching `clang`"
            )
        });
        let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
        bindings
            .write_to_file(out.join("petsc_bindings.rs"))
            .expect("writing the PETSc bindings");
    }

    #[derive(Debug)]
    struct RenameVec;

    impl bindgen::callbacks::ParseCallbacks for RenameVec {
        fn item_name(&self, item: bindgen::callbacks::ItemInfo<'_>) -> Option<String> {
            (item.name == "Vec").then(|| "PetscVec".to_string())
        }
    }

    /// PETSc from pkg-config's `petsc` (Debian's `libpetsc-real-dev`, or a cluster build: with
    /// `PETSC_DIR` set, `$PETSC_DIR/$PETSC_ARCH/lib/pkgconfig` is searched first, where PETSc's
    /// own `make install` puts `petsc.pc`), which also emits the link flags; MPI's include
    /// directories from pkg-config's `mpi` (PETSc's `petsc.pc` does not carry them).
    fn discover() -> Found {
        if let Some(dir) = std::env::var_os("PETSC_DIR") {
            let dir = PathBuf::from(dir);
            let arch = std::env::var_os("PETSC_ARCH").map(PathBuf::from);
            let lib = match &arch {
                Some(arch) => dir.join(arch).join("lib"),
                None => dir.join("lib"),
            };
            let mut path = lib.join("pkgconfig").into_os_string();
            if let Some(old) = std::env::var_os("PKG_CONFIG_PATH") {
                path.push(":");
                path.push(old);
            }
            std::env::set_var("PKG_CONFIG_PATH", path);
        }
        let petsc = pkg_config::Config::new()
            .probe("petsc")
            .or_else(|_| pkg_config::Config::new().probe("PETSc"))
            .unwrap_or_else(|e| {
                panic!(
                    "feature `petsc`: pkg-config could not find PETSc ({e}); install libpetsc-real-dev (see .ci/petsc.sh) \
                     or set PETSC_DIR (and PETSC_ARCH) to a PETSc build"
                )
            });
        let mut include_dirs = petsc.include_paths;
        if let Ok(mpi) = pkg_config::Config::new().cargo_metadata(false).probe("mpi") {
            include_dirs.extend(mpi.include_paths);
        }
        Found { include_dirs }
    }
}

#[cfg(feature = "trilinos")]
mod trilinos {
    use std::path::{Path, PathBuf};

    /// The Trilinos libraries the shim uses, most dependent first (the order a static link
    /// would need). `trilinos_epetraext` is there because ML's inline destructors reference
    /// EpetraExt symbols (a release link fails without it).
    const LIBRARIES: &[&str] = &[
        "noxepetra",
        "nox",
        "belosepetra",
        "belos",
        "ml",
        "ifpack",
        "aztecoo",
        "epetraext",
        "epetra",
        "teuchosremainder",
        "teuchosnumerics",
        "teuchoscomm",
        "teuchosparameterlist",
        "teuchosparser",
        "teuchoscore",
    ];

    /// Where Trilinos and MPI live.
    struct Found {
        include_dirs: Vec<PathBuf>,
        library_dirs: Vec<PathBuf>,
        /// Library file stem prefix: Debian names them `libtrilinos_<pkg>.so`, an upstream
        /// install `lib<pkg>.so`.
        library_prefix: String,
        mpi_include_dirs: Vec<PathBuf>,
        mpi_library_dirs: Vec<PathBuf>,
        mpi_libraries: Vec<String>,
    }

    pub fn build() {
        for path in [
            "src/backend/trilinos/ffi.rs",
            "src/backend/trilinos/nox_ffi.rs",
            "cpp",
            "cmake",
        ] {
            println!("cargo:rerun-if-changed={path}");
        }
        for var in ["Trilinos_DIR", "PERIDYN_TRILINOS_CMAKE"] {
            println!("cargo:rerun-if-env-changed={var}");
        }
        let found = discover();
        let mut build = cxx_build::bridges([
            "src/backend/trilinos/ffi.rs",
            "src/backend/trilinos/nox_ffi.rs",
        ]);
        build
            .file("cpp/src/trilinos_linear.cpp")
            .file("cpp/src/trilinos_nox.cpp")
            .std("c++17")
            .include("cpp/include")
            // OpenMPI's and MPICH's C++ bindings would need libmpi_cxx; the shim uses the C API.
            .define("OMPI_SKIP_MPICXX", None)
            .define("MPICH_SKIP_MPICXX", None);
        // -isystem: Trilinos headers trip -Wall -Wextra by the hundred.
        for dir in found.include_dirs.iter().chain(&found.mpi_include_dirs) {
            build
                .flag("-isystem")
                .flag(dir.to_str().expect("UTF-8 include path"));
        }
        build.compile("peridyn_trilinos");
        for dir in found.library_dirs.iter().chain(&found.mpi_library_dirs) {
            println!("cargo:rustc-link-search=native={}", dir.display());
        }
        for lib in LIBRARIES {
            println!("cargo:rustc-link-lib=dylib={}{lib}", found.library_prefix);
        }
        for lib in &found.mpi_libraries {
            println!("cargo:rustc-link-lib=dylib={lib}");
        }
    }

    /// With `Trilinos_DIR` set (or `PERIDYN_TRILINOS_CMAKE=1`), the CMake project in `cmake/`
    /// runs `find_package(Trilinos)` and `find_package(MPI)` and writes what it found;
    /// otherwise the Debian layout (`/usr/include/trilinos`, `libtrilinos_*.so` on the default
    /// path) and pkg-config's `mpi` are used, which needs none of the extra `-dev` packages
    /// CMake's `TrilinosConfig.cmake` insists on.
    fn discover() -> Found {
        let use_cmake = std::env::var_os("Trilinos_DIR").is_some()
            || std::env::var("PERIDYN_TRILINOS_CMAKE").is_ok_and(|v| v == "1");
        if use_cmake {
            return discover_with_cmake();
        }
        let mpi = pkg_config::Config::new()
            .cargo_metadata(false)
            .probe("mpi")
            .unwrap_or_else(|e| {
                panic!("feature `trilinos`: pkg-config could not find MPI ({e}); install libopenmpi-dev (see .ci/trilinos.sh)")
            });
        let include = PathBuf::from("/usr/include/trilinos");
        if !include.join("Epetra_config.h").exists() {
            panic!(
                "feature `trilinos`: no Trilinos headers in {} — install the Debian packages listed in .ci/trilinos.sh, \
                 or set Trilinos_DIR to the directory holding TrilinosConfig.cmake",
                include.display()
            );
        }
        Found {
            include_dirs: vec![include],
            library_dirs: Vec::new(),
            library_prefix: "trilinos_".into(),
            mpi_include_dirs: mpi.include_paths,
            mpi_library_dirs: mpi.link_paths,
            mpi_libraries: mpi.libs,
        }
    }

    fn discover_with_cmake() -> Found {
        let out = cmake::Config::new("cmake")
            .build_target("peridyn_trilinos_discovery")
            .very_verbose(false)
            .build();
        let report = out.join("build").join("trilinos_discovery.txt");
        parse_report(&report)
    }

    /// Reads `key=value;value;...` lines written by cmake/CMakeLists.txt.
    fn parse_report(path: &Path) -> Found {
        let text = std::fs::read_to_string(path)
            .unwrap_or_else(|e| panic!("feature `trilinos`: cannot read {}: {e}", path.display()));
        let get = |key: &str| -> Vec<String> {
            text.lines()
                .find_map(|l| l.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
                .map(|v| {
                    v.split(';')
                        .filter(|s| !s.is_empty())
                        .map(str::to_owned)
                        .collect()
                })
                .unwrap_or_default()
        };
        // The compiler's own directories must stay out of -isystem: re-adding /usr/include
        // breaks libstdc++'s #include_next <stdlib.h>.
        let paths = |key: &str| {
            get(key)
                .into_iter()
                .filter(|d| d != "/usr/include" && d != "/usr/local/include")
                .map(PathBuf::from)
                .collect()
        };
        let mut mpi_library_dirs = Vec::new();
        let mut mpi_libraries = Vec::new();
        for file in get("MPI_LIBRARIES") {
            let file = PathBuf::from(file);
            if let (Some(dir), Some(stem)) = (file.parent(), file.file_stem()) {
                mpi_library_dirs.push(dir.to_path_buf());
                let stem = stem.to_string_lossy();
                mpi_libraries.push(stem.strip_prefix("lib").unwrap_or(&stem).to_string());
            }
        }
        Found {
            include_dirs: paths("TRILINOS_INCLUDE_DIRS"),
            library_dirs: paths("TRILINOS_LIBRARY_DIRS"),
            library_prefix: get("TRILINOS_LIBRARY_PREFIX").concat(),
            mpi_include_dirs: paths("MPI_INCLUDE_DIRS"),
            mpi_library_dirs,
            mpi_libraries,
        }
    }
}
