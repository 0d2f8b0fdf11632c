//! Byte offsets (what spans hold) to LSP positions (lines and UTF-16 code units, what the
//! protocol counts in) and back. Scenes hold non-ASCII text (`×`, `°`, `…` in comments), so
//! a column is never a byte count. Every conversion clamps: a position past the end of a
//! line or of the text lands on that end, and an offset inside a character on its start.

use lsp_types::{Position, Range};

/// Where each line of a text starts.
pub struct LineIndex<'a> {
    text: &'a str,
    starts: Vec<usize>,
}

impl<'a> LineIndex<'a> {
    pub fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { text, starts }
    }

    /// The position of byte `offset` (clamped to the text, and to a character boundary).
    pub fn position(&self, offset: usize) -> Position {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = self.starts.partition_point(|&s| s <= offset) - 1;
        let start = self.starts[line];
        let character: usize = self.text[start..offset].chars().map(char::len_utf16).sum();
        Position::new(line as u32, character as u32)
    }

    pub fn range(&self, start: usize, end: usize) -> Range {
        Range::new(self.position(start), self.position(end.max(start)))
    }

    /// The byte offset of `p`: a line past the last is the end of the text, a character past
    /// the end of its line the end of that line (before its newline), a character inside a
    /// surrogate pair the start of that character.
    pub fn offset(&self, p: Position) -> usize {
        let Some(&start) = self.starts.get(p.line as usize) else { return self.text.len() };
        let end = self.starts.get(p.line as usize + 1).map_or(self.text.len(), |&next| next - 1);
        let mut units = 0usize;
        for (i, c) in self.text[start..end].char_indices() {
            if units + c.len_utf16() > p.character as usize {
                return start + i;
            }
            units += c.len_utf16();
        }
        end
    }

    /// The range of the whole text.
    pub fn all(&self) -> Range {
        self.range(0, self.text.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_count_utf16_units_not_bytes() {
        let text = "size = 64 × 32\n# 45°, 𝄞 x\nend";
        let ix = LineIndex::new(text);
        let x = text.find(" 32").unwrap() + 1;
        assert_eq!(ix.position(x), Position::new(0, 12));
        assert_eq!(ix.offset(Position::new(0, 12)), x);
        // `𝄞` is two UTF-16 units (and four bytes).
        let after = text.find(" x").unwrap() + 1;
        assert_eq!(ix.position(after), Position::new(1, 10));
        assert_eq!(ix.offset(Position::new(1, 10)), after);
        assert_eq!(ix.position(text.len()), Position::new(2, 3));
    }

    #[test]
    fn every_offset_round_trips() {
        let text = "a × b\r\n°°\n\n𝄞z";
        let ix = LineIndex::new(text);
        for (i, _) in text.char_indices().chain(std::iter::once((text.len(), ' '))) {
            assert_eq!(ix.offset(ix.position(i)), i, "offset {i}");
        }
    }

    #[test]
    fn out_of_range_clamps() {
        let text = "ab\n×y\n";
        let ix = LineIndex::new(text);
        assert_eq!(ix.offset(Position::new(0, 99)), 2);
        assert_eq!(ix.offset(Position::new(99, 0)), text.len());
        assert_eq!(ix.position(999), Position::new(2, 0));
        // Inside the two bytes of `×`: its start.
        assert_eq!(ix.position(4), Position::new(1, 0));
        let s = "𝄞";
        assert_eq!(LineIndex::new(s).offset(Position::new(0, 1)), 0, "inside a surrogate pair");
        assert_eq!(ix.all(), Range::new(Position::new(0, 0), Position::new(2, 0)));
    }
}
