//! A 5 × 7 pixel font for the plot's tick labels and axis names.
//!
//! plotters draws text only through a font library (`ttf`: font-kit and the system's
//! fontconfig; `ab_glyph`: a font file to embed) and panics without one, so the plot draws its
//! few characters itself: digits, `.`, `-`, `+`, `=`, `e`, and the letters of "strain",
//! "stress" and "E". No font file, no system library; the same pixels on every machine.

/// Rows of a glyph, top to bottom; bit 4 is the leftmost of the 5 columns.
type Glyph = [u8; 7];

/// The glyph of `c`, or `None` for characters the font lacks (drawn as a space).
pub fn glyph(c: char) -> Option<Glyph> {
    Some(match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '=' => [0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00],
        'e' => [0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E],
        's' => [0x00, 0x00, 0x0F, 0x10, 0x0E, 0x01, 0x1E],
        't' => [0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06],
        'r' => [0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10],
        'a' => [0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F],
        'i' => [0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E],
        'n' => [0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        _ => return None,
    })
}

/// Width of one character cell in font pixels (5 columns and a 1-pixel gap).
pub const ADVANCE: i32 = 6;
/// Height of a glyph in font pixels.
pub const HEIGHT: i32 = 7;

/// The font pixels that are set for `text` written from (0, 0) rightwards, as (column, row).
pub fn pixels(text: &str) -> Vec<(i32, i32)> {
    let mut set = Vec::new();
    for (k, c) in text.chars().enumerate() {
        let Some(rows) = glyph(c) else { continue };
        for (row, bits) in rows.iter().enumerate() {
            for column in 0..5 {
                if bits & (0x10 >> column) != 0 {
                    set.push((k as i32 * ADVANCE + column, row as i32));
                }
            }
        }
    }
    set
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_tick_label_character_has_a_glyph() {
        for c in "0123456789.-+=e strain stress E"
            .chars()
            .filter(|c| *c != ' ')
        {
            assert!(glyph(c).is_some(), "{c}");
        }
        assert!(glyph('Q').is_none());
        // "1" has 10 set pixels; the second character starts one advance further.
        assert_eq!(pixels("1").len(), 10);
        assert!(pixels("11").iter().any(|&(x, _)| x >= ADVANCE));
    }
}
