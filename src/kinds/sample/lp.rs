//! Light-position files (`.lp`), as RTI capture tools write them: a count of images, then
//! one `filename x y z` line per image giving the direction towards the light. Existing
//! captures load as they are.
//!
//! The tools' frame has x to the right of the image, y up it and z towards the camera;
//! tessera's has y down the rows (the row index), so y changes sign on reading.

/// One image of a capture and the direction of its light, in tessera's frame (unit length).
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
        out.push(LpEntry { file, direction: [v[0] / len, -v[1] / len, v[2] / len], line });
    }
    if out.len() < n {
        let last = text.lines().count().max(1);
        return Err(err(last, format!("the first line announces {n} images, the file lists {}", out.len())));
    }
    Ok(out)
}

/// `(tilt, slant)` in degrees of a unit direction: tilt from the x axis towards y in
/// [0, 360), slant from the z axis.
pub fn tilt_slant(d: [f64; 3]) -> (f64, f64) {
    let slant = d[2].clamp(-1.0, 1.0).acos().to_degrees();
    let tilt = d[1].atan2(d[0]).to_degrees().rem_euclid(360.0);
    (tilt, slant)
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
        // y up in the file, down the rows here.
        assert!((e[1].direction[1] + 0.707107).abs() < 1e-6);
        let (tilt, slant) = tilt_slant(e[0].direction);
        assert!(tilt.abs() < 1e-9 && (slant - 30.0).abs() < 1e-4, "{tilt} {slant}");
        let (tilt, slant) = tilt_slant(e[2].direction);
        assert!((tilt - 180.0).abs() < 1e-9 && (slant - 45.0).abs() < 1e-9);
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
