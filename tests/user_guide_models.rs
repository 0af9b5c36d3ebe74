//! The user guide's model pages against the registries: every material of
//! `peridyn::material::MATERIALS` and damage model of `peridyn::damage::DAMAGE_MODELS` has a
//! page (`docs/src/materials/<slug>.md`, `docs/src/damage/<slug>.md`, the slug being the deck
//! name lower-cased with spaces as hyphens), listed in `docs/src/SUMMARY.md` and in the overview
//! table of `materials.md` or `damage.md`, with hand-written prose and, between two marker
//! lines, a block generated here from the model's `ModelDeclaration`: its key table, its reach,
//! tangent, thermal strain, history and outputs, and its declared example. A page for no model
//! (a model this build does not run may keep a page while it has one) and a block that differs
//! from what the declaration gives are failures, so the guide cannot drift from what the deck
//! reader accepts. `PERIDYN_BLESS=1` rewrites the blocks (the prose stays as it is).

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use peridyn::damage::{DAMAGE_MODELS, UNBUILT_DAMAGE_MODELS};
use peridyn::material::{MATERIALS, UNBUILT_MATERIALS};
use peridyn::model::{FieldCarrier, ModelDeclaration};

/// The line that opens a page's generated block.
const BEGIN: &str =
    "<!-- generated from the registry by tests/user_guide_models.rs: do not edit -->";

/// The line that closes it.
const END: &str = "<!-- end of generated -->";

/// The environment variable that makes the test rewrite the blocks instead of failing.
const BLESS: &str = "PERIDYN_BLESS";

/// Which registry a page documents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Material,
    Damage,
}

impl Kind {
    /// The folder of its pages under `docs/src`.
    fn folder(self) -> &'static str {
        match self {
            Kind::Material => "materials",
            Kind::Damage => "damage",
        }
    }

    /// The deck's list and the key naming the model in it, for the example's wrapper.
    fn wrapper(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Kind::Material => ("Materials", "My Material", "Material Model"),
            Kind::Damage => ("Damage Models", "My Damage Model", "Damage Model"),
        }
    }
}

/// One model with a page: its declaration and which registry holds it.
struct Model {
    declaration: &'static ModelDeclaration,
    kind: Kind,
}

/// The book's source folder.
fn book_source() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("docs")
        .join("src")
}

/// The page name of a model: its deck name lower-cased, spaces as hyphens.
fn slug(deck_name: &str) -> String {
    deck_name.to_lowercase().replace(' ', "-")
}

/// A table cell: `|` escaped so that it does not end the cell.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

/// `a`, `b` and `c` as inline code, comma-separated.
fn code_list<'a>(names: impl IntoIterator<Item = &'a str>) -> String {
    names
        .into_iter()
        .map(|name| format!("`{name}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The generated block of a model's page, marker lines included.
fn render(model: &Model) -> String {
    let d = model.declaration;
    let mut out = String::new();
    writeln!(out, "{BEGIN}").unwrap();
    writeln!(out).unwrap();
    writeln!(out, "## Keys").unwrap();
    writeln!(out).unwrap();
    let (list, _, name_key) = model.kind.wrapper();
    write!(
        out,
        "`{name_key}: \"{}\"` in an entry of the deck's `{list}`",
        d.deck_name
    )
    .unwrap();
    if !d.aliases.is_empty() {
        write!(
            out,
            " (also read as {})",
            code_list(d.aliases.iter().copied())
        )
        .unwrap();
    }
    writeln!(out, ", with these keys:").unwrap();
    writeln!(out).unwrap();
    if d.deck_keys.is_empty() {
        writeln!(out, "none besides the model's name.").unwrap();
    } else {
        writeln!(out, "| key | meaning | unit | default |").unwrap();
        writeln!(out, "|---|---|---|---|").unwrap();
        for key in d.deck_keys {
            writeln!(
                out,
                "| `{}` | {} | {} | {} |",
                key.key,
                cell(key.meaning),
                cell(key.unit),
                cell(key.default)
            )
            .unwrap();
        }
    }
    writeln!(out).unwrap();
    for line in capabilities(model) {
        writeln!(out, "- {line}").unwrap();
    }
    writeln!(out).unwrap();
    if d.example.is_empty() {
        writeln!(
            out,
            "This build reads the model's keys but does not run it."
        )
        .unwrap();
    } else {
        writeln!(
            out,
            "An example, in consistent units for a body of unit point spacing and horizon 1.8 \
             (the registry's conformance suite reads and runs it); the list goes under the \
             deck's `Peridigm:`."
        )
        .unwrap();
        writeln!(out).unwrap();
        writeln!(out, "```yaml").unwrap();
        let (list, entry, name_key) = model.kind.wrapper();
        writeln!(out, "{list}:").unwrap();
        writeln!(out, "  {entry}:").unwrap();
        writeln!(out, "    {name_key}: \"{}\"", d.deck_name).unwrap();
        for line in d.example.lines() {
            writeln!(out, "    {line}").unwrap();
        }
        writeln!(out, "```").unwrap();
    }
    writeln!(out).unwrap();
    write!(out, "{END}").unwrap();
    out
}

/// The lines of a page that say how the model runs: reach, tangent, thermal strain, history
/// and outputs.
fn capabilities(model: &Model) -> Vec<String> {
    let d = model.declaration;
    let layers = d.reach.ghost_layers();
    let mut lines = vec![format!(
        "**Reach**: {} ({layers} ghost layer{} on MPI ranks).",
        d.reach.pattern_name(),
        if layers == 1 { "" } else { "s" }
    )];
    if model.kind == Kind::Material {
        lines.push(format!("**Tangent**: {}.", d.tangent.describe()));
    }
    if model.kind == Kind::Material || d.thermal_strain {
        lines.push(format!(
            "**Thermal strain**: {}.",
            if d.thermal_strain {
                "yes, with `Thermal Expansion Coefficient`"
            } else {
                "no"
            }
        ));
    }
    if d.small_displacement {
        lines.push(
            "**Small displacements**: linearized about the reference configuration.".to_string(),
        );
    }
    for (carrier, word) in [(FieldCarrier::Point, "point"), (FieldCarrier::Bond, "bond")] {
        let names = d
            .fields
            .iter()
            .filter(|field| field.staged && field.carrier == carrier)
            .map(|field| field.name);
        let names = code_list(names);
        if !names.is_empty() {
            lines.push(format!(
                "**History per {word}** (committed when a step is accepted): {names}."
            ));
        }
    }
    lines.push(format!(
        "**Outputs of its own**: {}.",
        if d.outputs.is_empty() {
            "none".to_string()
        } else {
            code_list(d.outputs.iter().copied())
        }
    ));
    lines
}

/// Every model that must have a page: the built ones, and the unbuilt ones whose page exists.
fn models(source: &Path) -> Vec<Model> {
    let mut models = Vec::new();
    for entry in MATERIALS {
        models.push(Model {
            declaration: entry.declaration,
            kind: Kind::Material,
        });
    }
    for entry in DAMAGE_MODELS {
        models.push(Model {
            declaration: entry.declaration,
            kind: Kind::Damage,
        });
    }
    let unbuilt = UNBUILT_MATERIALS
        .iter()
        .map(|entry| (entry.declaration, Kind::Material))
        .chain(
            UNBUILT_DAMAGE_MODELS
                .iter()
                .map(|entry| (entry.declaration, Kind::Damage)),
        );
    for (declaration, kind) in unbuilt {
        if page_path(source, kind, declaration).exists() {
            models.push(Model { declaration, kind });
        }
    }
    models
}

/// Where the page of a model lives.
fn page_path(source: &Path, kind: Kind, declaration: &ModelDeclaration) -> PathBuf {
    source
        .join(kind.folder())
        .join(format!("{}.md", slug(declaration.deck_name)))
}

/// The page's text with its generated block made `block`, or what is wrong with the page.
fn with_block(text: &str, block: &str) -> Result<String, String> {
    let begin = text.find(BEGIN);
    let end = text.find(END);
    match (begin, end) {
        (None, None) => Ok(format!("{}\n\n{block}\n", text.trim_end())),
        (Some(b), Some(e)) if b < e && text.matches(BEGIN).count() == 1 => {
            Ok(format!("{}{block}{}", &text[..b], &text[e + END.len()..]))
        }
        _ => Err(format!(
            "its marker lines are broken: it needs one `{BEGIN}` followed by one `{END}`"
        )),
    }
}

/// What is wrong with the page of `model`, or `None`; rewrites its block when `bless`.
fn check_page(source: &Path, summary: &str, model: &Model, bless: bool) -> Option<String> {
    let d = model.declaration;
    let path = page_path(source, model.kind, d);
    let shown = path
        .strip_prefix(env!("CARGO_MANIFEST_DIR"))
        .unwrap_or(&path);
    let relative = format!("{}/{}.md", model.kind.folder(), slug(d.deck_name));
    let block = render(model);
    let Ok(text) = fs::read_to_string(&path) else {
        return Some(format!(
            "the model \"{}\" has no page: write {} (a `# {}` title, prose for users, then \
             run with {BLESS}=1 to add its generated block) and list it in docs/src/SUMMARY.md",
            d.deck_name,
            shown.display(),
            d.deck_name
        ));
    };
    let mut problems = Vec::new();
    if !summary.contains(&format!("]({relative})")) {
        problems.push(format!("docs/src/SUMMARY.md does not list ({relative})"));
    }
    let overview = format!("{}.md", model.kind.folder());
    let table = fs::read_to_string(source.join(&overview)).unwrap_or_default();
    if !table.contains(&format!("]({relative})")) {
        problems.push(format!(
            "the overview table of docs/src/{overview} does not link ({relative})"
        ));
    }
    let title = format!("# {}", d.deck_name);
    if text.lines().next() != Some(title.as_str()) {
        problems.push(format!("its first line is not `{title}`"));
    }
    let prose = text
        .split(BEGIN)
        .next()
        .unwrap_or("")
        .lines()
        .skip(1)
        .filter(|line| !line.trim().is_empty())
        .count();
    if prose == 0 {
        problems.push("it has no prose above the generated block".to_string());
    }
    match with_block(&text, &block) {
        Err(problem) => problems.push(problem),
        Ok(expected) if expected != text => {
            if bless {
                fs::write(&path, expected).expect("the page is writable");
            } else {
                problems.push(format!(
                    "its generated block is missing or differs from the declaration (run with \
                     {BLESS}=1 to rewrite it); expected:\n{block}"
                ));
            }
        }
        Ok(_) => {}
    }
    (!problems.is_empty()).then(|| format!("{}: {}", shown.display(), problems.join("; ")))
}

/// The pages of `kind` that document no model of `models`.
fn orphan_pages(source: &Path, kind: Kind, models: &[Model]) -> Vec<String> {
    let folder = source.join(kind.folder());
    let mut orphans = Vec::new();
    for file in fs::read_dir(&folder).expect("the page folder exists") {
        let path = file.unwrap().path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
            continue;
        };
        let known = models
            .iter()
            .any(|m| m.kind == kind && format!("{}.md", slug(m.declaration.deck_name)) == name);
        if !known {
            orphans.push(format!(
                "docs/src/{}/{name} is the page of no model in the registry: rename it to a \
                 model's slug (its deck name lower-cased, spaces as hyphens) or remove it",
                kind.folder()
            ));
        }
    }
    orphans
}

#[test]
fn every_model_page_carries_the_key_table_of_its_declaration() {
    let source = book_source();
    let bless = std::env::var_os(BLESS).is_some_and(|v| v == "1");
    let summary = fs::read_to_string(source.join("SUMMARY.md")).expect("SUMMARY.md exists");
    let models = models(&source);
    let mut problems: Vec<String> = models
        .iter()
        .filter_map(|model| check_page(&source, &summary, model, bless))
        .collect();
    for kind in [Kind::Material, Kind::Damage] {
        problems.extend(orphan_pages(&source, kind, &models));
    }
    assert!(
        problems.is_empty(),
        "{} problem(s) with the model pages of the user guide:\n\n{}",
        problems.len(),
        problems.join("\n\n")
    );
}

#[test]
fn the_generated_block_renders_a_declaration() {
    let model = Model {
        declaration: MATERIALS
            .iter()
            .find(|entry| entry.deck_name() == "Elastic")
            .expect("Elastic is a material of the build")
            .declaration,
        kind: Kind::Material,
    };
    let block = render(&model);
    assert!(block.starts_with(BEGIN) && block.ends_with(END));
    // `Density`'s documentation in src/material/keys.rs.
    assert!(block.contains("| `Density` | mass density ρ | mass/length³ | required |"));
    assert!(block.contains("(also read as `Elastic Partial Volume`)"));
    assert!(block.contains("    Material Model: \"Elastic\"\n    Density: 2.0\n"));
    assert_eq!(
        slug("Time Dependent Critical Stretch"),
        "time-dependent-critical-stretch"
    );
    assert_eq!(cell("(|Y| − ζ)/ζ"), "(\\|Y\\| − ζ)/ζ");
}
