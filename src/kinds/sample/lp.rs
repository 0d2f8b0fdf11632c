//! Light-position files (`.lp`), as RTI capture tools write them: a count of images, then
//! one `filename x y z` line per image giving the direction towards the light. Existing
//! captures load as they are.
//!
//! Directions stay in the tools' frame (x to the right of the image, y up it, z towards the
//! camera); `Light::from_rti_direction` turns them into tessera's, whose y runs down the rows.

/// One image of a capture and the direction of its light, in the file's frame (unit length).
#[derive(Clone, Debug, PartialEq)]
pub struct LpEntry {
    pub file: String,
    pub direction: [f64; 3],
    /// 1-based line of the file, for messages.
    pub line: usize,
}

/// Why a light-position file cannot be read: the message names the line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LpError {
    pub line: usize,
    pub message: String,
}

/// More images than any capture dome holds; a count beyond it is a malformed file, not a
/// reason to allocate.
pub const MAX_IMAGES: usize = 4096;

/// Parses a light-position file. Blank lines and `#` comments are skipped; a file name may
/// hold spaces (the last three fields are the direction). Every direction must point above
/// the surface (z > 0).
pub fn parse(text: &str) -> Result<Vec<LpEntry>, LpError> {
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split('#').next().unwrap_or("").trim()))
        .filter(|(_, l)| !l.is_empty());
    let err = |line: usize, message: String| LpError { line, message };
    let (first, count) =
        lines.next().ok_or_else(|| err(1, "the file is empty: expected the number of images".into()))?;
    let n: usize = count.parse().map_err(|_| err(first, format!("expected the number of images, found `{count}`")))?;
    if n == 0 || n > MAX_IMAGES {
        return Err(err(first, format!("the number of images must be from 1 to {MAX_IMAGES}, found {n}")));
    }
    let mut out = Vec::with_capacity(n);
    for (line, text) in lines {
        if out.len() == n {
            return Err(err(line, format!("more lines than the {n} images the first line announces")));
        }
        let fields: Vec<&str> = text.split_whitespace().collect();
        if fields.len() < 4 {
            return Err(err(line, format!("expected `filename x y z`, found `{text}`")));
        }
        let (name, xyz) = fields.split_at(fields.len() - 3);
        let mut v = [0.0f64; 3];
        for (slot, f) in v.iter_mut().zip(xyz) {
            *slot = f
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| err(line, format!("`{f}` is not a number")))?;
        }
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if len < 1e-9 {
            return Err(err(line, "the light direction is the zero vector".into()));
        }
        if v[2] <= 0.0 {
            return Err(err(line, format!("the light is not above the surface (z = {})", v[2])));
        }
        let file = name.join(" ");
        out.push(LpEntry { file, direction: [v[0] / len, v[1] / len, v[2] / len], line });
    }
    if out.len() < n {
        let last = text.lines().count().max(1);
        return Err(err(last, format!("the first line announces {n} images, the file lists {}", out.len())));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_capture_file() {
        let text = "3\nimg_00.png 0.5 0.0 0.866025\n# a comment\n\nimg 01.png 0 0.707107 0.707107\nimg_02.png -1 0 1\n";
        let e = parse(text).unwrap();
        assert_eq!(e.len(), 3);
        assert_eq!(e[1].file, "img 01.png");
        assert_eq!(e[1].line, 5);
        assert!((e[1].direction[1] - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        // y up the image in the file, down the rows in tessera: tilt 90° there is 270° here.
        let [x, y, z] = e[1].direction;
        let l = crate::synth::relight::Light::from_rti_direction(x, y, z);
        assert!((l.tilt_deg - 270.0).abs() < 1e-6 && (l.slant_deg - 45.0).abs() < 1e-4, "{l:?}");
        let [x, y, z] = e[2].direction;
        let l = crate::synth::relight::Light::from_rti_direction(x, y, z);
        assert!((l.tilt_deg - 180.0).abs() < 1e-9 && (l.slant_deg - 45.0).abs() < 1e-9, "{l:?}");
    }

    #[test]
    fn malformed_files_name_the_line() {
        for (text, line, says) in [
            ("", 1, "empty"),
            ("x\n", 1, "number of images"),
            ("0\n", 1, "from 1 to"),
            ("99999999999\n", 1, "from 1 to"),
            ("2\na.png 0 0 1\n", 2, "announces 2 images"),
            ("1\na.png 0 0 1\nb.png 0 0 1\n", 3, "more lines"),
            ("1\na.png 0 1\n", 2, "filename x y z"),
            ("1\na.png 0 nan 1\n", 2, "not a number"),
            ("1\na.png 0 0 0\n", 2, "zero vector"),
            ("1\na.png 0 1 -1\n", 2, "not above"),
        ] {
            let e = parse(text).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e:?}");
            assert!(e.message.contains(says), "{text:?}: {}", e.message);
        }
    }
}
