//! Cutting the user's text into tokens: numbers, identifiers and punctuation, each with its
//! byte range for error messages.

use super::{Kind, Result, Source, Token, ONE_CHAR_PUNCTUATION, TWO_CHAR_PUNCTUATION};
use crate::expression::ExpressionError;

pub(super) fn lex(source: &Source) -> Result<Vec<Token>> {
    let text = source.text;
    let bytes = text.as_bytes();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let byte = bytes[i];
        let next = bytes.get(i + 1).copied();
        if byte.is_ascii_whitespace() {
            i += 1;
        } else if byte == b'/' && next == Some(b'/') {
            i = text[i..]
                .find('\n')
                .map_or(bytes.len(), |newline| i + newline);
        } else if byte == b'/' && next == Some(b'*') {
            match text[i + 2..].find("*/") {
                Some(end) => i += end + 4,
                None => return Err(source.syntax(i, "comment `/*` is never closed by `*/`")),
            }
        } else if byte == b'\\' && matches!(next, Some(b'{') | Some(b'}')) {
            // YAML decks escape braces; the deck reader may or may not have removed the `\`.
            let brace = if next == Some(b'{') { "{" } else { "}" };
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: brace.to_string(),
                start: i,
                end: i + 2,
            });
            i += 2;
        } else if byte.is_ascii_digit()
            || (byte == b'.' && next.is_some_and(|b| b.is_ascii_digit()))
        {
            let token = lex_number(source, i)?;
            i = token.end;
            tokens.push(token);
        } else if byte.is_ascii_alphabetic() || byte == b'_' {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            tokens.push(Token {
                kind: Kind::Identifier,
                text: text[start..i].to_string(),
                start,
                end: i,
            });
        } else if let Some(pair) = TWO_CHAR_PUNCTUATION
            .iter()
            .find(|pair| text[i..].starts_with(**pair))
        {
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: pair.to_string(),
                start: i,
                end: i + 2,
            });
            i += 2;
        } else if ONE_CHAR_PUNCTUATION.as_bytes().contains(&byte) {
            tokens.push(Token {
                kind: Kind::Punctuation,
                text: char::from(byte).to_string(),
                start: i,
                end: i + 1,
            });
            i += 1;
        } else {
            return Err(unexpected_character(source, i));
        }
    }
    Ok(tokens)
}

/// The number literal starting at byte `start` (digits, an optional fraction and exponent);
/// a literal running into letters (`2x`) is an error.
fn lex_number(source: &Source, start: usize) -> Result<Token> {
    let text = source.text;
    let bytes = text.as_bytes();
    let mut i = start;
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        i += 1;
    }
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
    }
    if i < bytes.len() && matches!(bytes[i], b'e' | b'E') {
        let mut j = i + 1;
        if j < bytes.len() && matches!(bytes[j], b'+' | b'-') {
            j += 1;
        }
        if j < bytes.len() && bytes[j].is_ascii_digit() {
            i = j;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
        }
    }
    if i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || matches!(bytes[i], b'_' | b'.')) {
        let mut end = i;
        while end < bytes.len()
            && (bytes[end].is_ascii_alphanumeric() || matches!(bytes[end], b'_' | b'.'))
        {
            end += 1;
        }
        return Err(source.syntax(
            start,
            format!(
                "`{}` is not a number (write `2*x`, not `2x`; exponents as `1.5e-3`)",
                &text[start..end]
            ),
        ));
    }
    let literal = &text[start..i];
    let number: f64 = literal
        .parse()
        .map_err(|_| source.syntax(start, format!("`{literal}` is not a valid number")))?;
    if !number.is_finite() {
        return Err(source.syntax(start, format!("`{literal}` is too large for a double")));
    }
    Ok(Token {
        kind: Kind::Number(number),
        text: literal.to_string(),
        start,
        end: i,
    })
}

/// The error for a character no token starts with, with a hint for the common C/C++ ones.
fn unexpected_character(source: &Source, i: usize) -> ExpressionError {
    let text = source.text;
    let character = text[i..].chars().next().unwrap_or('?');
    let hint = match character {
        '&' => " (logical and is `&&`)",
        '|' => " (logical or is `||`)",
        ':' if text[i..].starts_with("::") => {
            " (call functions by their plain name, e.g. `sin(x)`)"
        }
        '?' | ':' => " (the `?:` operator is not supported; use if/else)",
        '[' | ']' => " (arrays are not supported)",
        _ => "",
    };
    source.syntax(i, format!("unexpected character `{character}`{hint}"))
}
