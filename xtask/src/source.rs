//! Reading Rust sources as lines of code: the helpers `long-functions`, `rooms` and
//! `import-circles` share.

use std::path::{Path, PathBuf};

/// Every `.rs` file under `root`, sorted by path component (the order of Python's
/// `sorted(Path.rglob("*.rs"))`, which the ported scripts used).
pub fn rust_files(root: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    collect(root, &mut found);
    found.sort();
    found
}

fn collect(folder: &Path, found: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(folder) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let Ok(kind) = entry.file_type() else {
            continue;
        };
        if kind.is_dir() {
            collect(&path, found);
        } else if path.extension().is_some_and(|e| e == "rs") && path.is_file() {
            found.push(path);
        }
    }
}

/// The lines of a text, split as Python's `str.splitlines` splits ordinary text (`\n`,
/// `\r\n` and `\r` end a line; no empty last line after a final line break).
pub fn lines(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let bytes = text.as_bytes();
    let mut start = 0;
    let mut k = 0;
    while k < bytes.len() {
        match bytes[k] {
            b'\n' => {
                out.push(&text[start..k]);
                start = k + 1;
            }
            b'\r' => {
                out.push(&text[start..k]);
                if bytes.get(k + 1) == Some(&b'\n') {
                    k += 1;
                }
                start = k + 1;
            }
            _ => {}
        }
        k += 1;
    }
    if start < bytes.len() {
        out.push(&text[start..]);
    }
    out
}

/// A file's text, with invalid UTF-8 replaced (a source file is UTF-8; this never fails on
/// a stray byte).
pub fn read_text(path: &Path) -> String {
    match std::fs::read(path) {
        Ok(bytes) => String::from_utf8_lossy(&bytes).into_owned(),
        Err(_) => String::new(),
    }
}

/// One line without its `//` comment, with every string literal emptied to `""` and every
/// character literal to `''`, so that the braces left are code's.
pub fn code_of(line: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let no_strings = blank_literals(&chars, '"', string_end);
    let no_chars = blank_literals(&no_strings, '\'', char_end);
    let text: String = no_chars.into_iter().collect();
    match text.find("//") {
        Some(at) => text[..at].to_string(),
        None => text,
    }
}

/// Replaces each literal that `end` recognises at a `quote` by two quotes, scanning left to
/// right as a regular expression's substitution does.
fn blank_literals(
    chars: &[char],
    quote: char,
    end: fn(&[char], usize) -> Option<usize>,
) -> Vec<char> {
    let mut out = Vec::with_capacity(chars.len());
    let mut k = 0;
    while k < chars.len() {
        if chars[k] == quote {
            if let Some(last) = end(chars, k) {
                out.push(quote);
                out.push(quote);
                k = last + 1;
                continue;
            }
        }
        out.push(chars[k]);
        k += 1;
    }
    out
}

/// The closing quote of a string literal opened at `start`: escapes (`\` and one character)
/// and any other character but a quote may come between (`"(\\.|[^"\\])*"`).
fn string_end(chars: &[char], start: usize) -> Option<usize> {
    let mut k = start + 1;
    while k < chars.len() {
        match chars[k] {
            '\\' if k + 1 < chars.len() => k += 2,
            '\\' => return None,
            '"' => return Some(k),
            _ => k += 1,
        }
    }
    None
}

/// The closing quote of a character literal opened at `start`: one escape or one character
/// other than a quote or a backslash (`'(\\.|[^'\\])'`).
fn char_end(chars: &[char], start: usize) -> Option<usize> {
    match chars.get(start + 1)? {
        '\\' => {
            (chars.get(start + 3) == Some(&'\'') && start + 2 < chars.len()).then_some(start + 3)
        }
        '\'' => None,
        _ => (chars.get(start + 2) == Some(&'\'')).then_some(start + 2),
    }
}

/// The name of the function a line declares (`pub(crate) const unsafe extern "C" fn name`),
/// when the line starts with a function's head.
pub fn function_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    if let Some(after) = keyword(rest, "pub") {
        let after = match after.strip_prefix('(') {
            Some(inner) => &inner[inner.find(')')? + 1..],
            None => after,
        };
        if let Some(spaced) = spaces(after) {
            rest = spaced;
        }
    }
    for word in ["const", "async", "unsafe"] {
        if let Some(spaced) = keyword(rest, word).and_then(spaces) {
            rest = spaced;
        }
    }
    if let Some(spaced) = keyword(rest, "extern").and_then(spaces) {
        if let Some(spaced) = spaced.strip_prefix("\"C\"").and_then(spaces) {
            rest = spaced;
        }
    }
    let name = spaces(keyword(rest, "fn")?)?;
    let end = name
        .char_indices()
        .find(|(_, c)| !(c.is_alphanumeric() || *c == '_'))
        .map_or(name.len(), |(at, _)| at);
    (end > 0).then(|| &name[..end])
}

fn keyword<'a>(text: &'a str, word: &str) -> Option<&'a str> {
    text.strip_prefix(word)
}

/// The text after at least one whitespace character, or None when none follows.
fn spaces(text: &str) -> Option<&str> {
    let trimmed = text.trim_start();
    (trimmed.len() < text.len()).then_some(trimmed)
}

/// The number of lines from `first` to the brace that closes the item opened there, or None
/// for a declaration (a line ending in `;` before any brace) or an item never closed.
pub fn item_length(lines: &[&str], first: usize) -> Option<usize> {
    let mut depth: i64 = 0;
    let mut opened = false;
    for (end, line) in lines.iter().enumerate().skip(first) {
        let code = code_of(line);
        for ch in code.chars() {
            if ch == '{' {
                depth += 1;
                opened = true;
            } else if ch == '}' {
                depth -= 1;
            }
        }
        if opened && depth == 0 {
            return Some(end - first + 1);
        }
        if !opened && code.trim_end().ends_with(';') {
            return None;
        }
    }
    None
}

/// A path as the scripts printed it: relative paths as given, joined with `/`.
pub fn shown(path: &Path) -> String {
    path.to_string_lossy().into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_and_comments_lose_their_braces() {
        assert_eq!(code_of(r#"let s = "{"; // }"#), r#"let s = ""; "#);
        assert_eq!(
            code_of(r"let c = '{'; let d = '\''; x"),
            "let c = ''; let d = ''; x"
        );
        assert_eq!(code_of(r#"a "b\"c" d"#), r#"a "" d"#);
        // A lifetime is not a character literal.
        assert_eq!(code_of("fn f<'a>(x: &'a str) {"), "fn f<'a>(x: &'a str) {");
        // A string left open keeps its text (no closing quote, no literal).
        assert_eq!(code_of(r#"let s = "abc\"#), r#"let s = "abc\"#);
    }

    #[test]
    fn function_heads_of_every_shape_are_found() {
        assert_eq!(
            function_name("    pub(crate) const unsafe fn go(x: u8) {"),
            Some("go")
        );
        assert_eq!(
            function_name("pub extern \"C\" fn callback() {"),
            Some("callback")
        );
        assert_eq!(function_name("async fn run()"), Some("run"));
        assert_eq!(function_name("let fn_x = 3;"), None);
        assert_eq!(function_name("// fn commented()"), None);
        assert_eq!(function_name("pubfn x()"), None);
    }

    #[test]
    fn items_end_at_their_closing_brace() {
        let text = ["fn a() {", "    let s = \"}\";", "}", "fn b();"];
        assert_eq!(item_length(&text, 0), Some(3));
        assert_eq!(item_length(&text, 3), None);
        assert_eq!(lines("a\r\nb\rc\n"), vec!["a", "b", "c"]);
    }
}
