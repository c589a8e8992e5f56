//! ArUco dictionaries: OpenCV's predefined ones (embedded data) and custom ones read from
//! OpenCV's YAML files.
//!
//! A marker's code is its `n x n` inner bits, row-major, with the top-left cell in the most
//! significant of the `n * n` low bits of a `u64` (OpenCV's `getBitsFromByteList` order; 1 =
//! white). The predefined bits come from OpenCV 5.0 itself through
//! `data/gen_dictionaries.py`; OpenCV's `_50`, `_100` and `_250` sets are prefixes of the
//! `_1000` set, so each marker size is stored once and each dictionary keeps its own
//! `maxCorrectionBits`.
//!
//! Rotations follow OpenCV: rotation `r` of a code is the code turned `r` times by
//! `rot[row][col] = bits[col][n - 1 - row]`, and a candidate whose cells equal rotation `r` of
//! marker `id` is identified as `(id, r)`.

use crate::error::MarkersError;
use std::collections::HashMap;
use std::path::Path;

/// The embedded predefined dictionaries (see `data/gen_dictionaries.py`).
const PREDEFINED: &str = include_str!("../data/aruco_dictionaries.txt");

/// OpenCV's default `errorCorrectionRate`: the share of `maxCorrectionBits` that detection may
/// correct.
pub const DEFAULT_ERROR_CORRECTION_RATE: f64 = 0.6;

/// The names [`Dictionary::predefined`] accepts (besides OpenCV's `DICT_6X6_250` spelling).
pub const PREDEFINED_NAMES: [&str; 17] = [
    "4x4_50", "4x4_100", "4x4_250", "4x4_1000", "5x5_50", "5x5_100", "5x5_250", "5x5_1000",
    "6x6_50", "6x6_100", "6x6_250", "6x6_1000", "7x7_50", "7x7_100", "7x7_250", "7x7_1000",
    "original",
];

/// A set of ArUco markers of one size, with a fast lookup of observed bits.
#[derive(Clone, Debug)]
pub struct Dictionary {
    name: String,
    marker_size: u32,
    max_correction_bits: u32,
    codes: Vec<u64>,
    /// The 4 rotations of every code, OpenCV's order.
    rotations: Vec<[u64; 4]>,
    /// Exact lookup: code of some rotation -> (id, rotation); the first id and rotation win,
    /// as OpenCV's linear search would.
    exact: HashMap<u64, (u32, u8)>,
}

/// A marker identified from its bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Identified {
    /// Index of the marker in the dictionary.
    pub id: u32,
    /// How many quarter turns (OpenCV's rotation index, 0..4) turn the marker's own code into
    /// the observed bits.
    pub rotation: u8,
    /// Number of cells that disagree with that rotation of the code.
    pub hamming: u32,
}

impl Dictionary {
    /// A dictionary from its codes (rotation 0, see the module doc for the bit order).
    /// `marker_size` must be 2..=8 and every code must fit in `marker_size²` bits.
    pub fn new(
        name: impl Into<String>,
        marker_size: u32,
        max_correction_bits: u32,
        codes: Vec<u64>,
    ) -> Result<Self, MarkersError> {
        let name = name.into();
        let invalid = |message: String| MarkersError::InvalidDictionary {
            name: name.clone(),
            message,
        };
        if !(2..=8).contains(&marker_size) {
            return Err(invalid(format!(
                "marker size {marker_size} is not in 2..=8"
            )));
        }
        let cells = marker_size * marker_size;
        if let Some((i, c)) = codes
            .iter()
            .enumerate()
            .find(|(_, c)| cells < 64 && **c >> cells != 0)
        {
            return Err(invalid(format!(
                "marker {i}: code {c:#x} has more than {cells} bits"
            )));
        }
        if codes.len() > u32::MAX as usize {
            return Err(invalid("too many markers".into()));
        }
        let rotations: Vec<[u64; 4]> = codes
            .iter()
            .map(|&c| all_rotations(c, marker_size))
            .collect();
        let mut exact = HashMap::with_capacity(codes.len() * 4);
        for (id, rots) in rotations.iter().enumerate() {
            for (r, &code) in rots.iter().enumerate() {
                exact.entry(code).or_insert((id as u32, r as u8));
            }
        }
        Ok(Self {
            name,
            marker_size,
            max_correction_bits,
            codes,
            rotations,
            exact,
        })
    }

    /// One of OpenCV's predefined dictionaries by name: `4x4_50` … `7x7_1000`, `original`, or
    /// OpenCV's spelling (`DICT_6X6_250`, `DICT_ARUCO_ORIGINAL`), case-insensitive.
    pub fn predefined(name: &str) -> Result<Self, MarkersError> {
        let key = canonical_name(name).ok_or_else(|| MarkersError::UnknownDictionary {
            name: name.to_string(),
            known: PREDEFINED_NAMES.join(", "),
        })?;
        let (set, count, max_corr) = PREDEFINED
            .lines()
            .filter_map(|l| l.strip_prefix("dict "))
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|f| f.len() == 4 && f[0] == key)
            .map(|f| (f[1], parse_num(f[2]), parse_num(f[3])))
            .expect("every predefined name has a dict line");
        let mut lines = PREDEFINED.lines();
        let header = lines
            .by_ref()
            .find(|l| l.split_whitespace().nth(1) == Some(set) && l.starts_with("set "))
            .expect("every dict line names a set");
        let size = parse_num(header.split_whitespace().nth(2).expect("set size"));
        let codes = lines
            .take(count as usize)
            .map(|l| u64::from_str_radix(l.trim(), 16).expect("embedded hex code"))
            .collect();
        Self::new(key, size, max_corr, codes)
    }

    /// A custom dictionary from an OpenCV FileStorage YAML file (`nmarkers`, `markersize`,
    /// optional `maxCorrectionBits` (default 0, as OpenCV), `marker_0` … as strings of `0`/`1`
    /// cells, row-major), such as the tutorial's `tutorial_dict.yml`. The dictionary is named
    /// after the file's stem.
    pub fn from_opencv_yaml(path: impl AsRef<Path>) -> Result<Self, MarkersError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| MarkersError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let fail = |message: String| MarkersError::Dictionary {
            path: path.to_path_buf(),
            message,
        };
        let mut values: HashMap<String, (usize, String)> = HashMap::new();
        for (n, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with('%') || line == "---" {
                continue;
            }
            let Some((key, value)) = line.split_once(':') else {
                return Err(fail(format!(
                    "line {}: expected 'key: value', found '{line}'",
                    n + 1
                )));
            };
            let value = value
                .split('#')
                .next()
                .unwrap_or("")
                .trim()
                .trim_matches('"')
                .to_string();
            values.insert(key.trim().to_string(), (n + 1, value));
        }
        let int = |key: &str, default: Option<u32>| -> Result<u32, MarkersError> {
            match values.get(key) {
                Some((line, v)) => v
                    .parse()
                    .map_err(|_| fail(format!("line {line}: {key} '{v}' is not a whole number"))),
                None => default.ok_or_else(|| fail(format!("no '{key}' entry"))),
            }
        };
        let nmarkers = int("nmarkers", None)?;
        let size = int("markersize", None)?;
        let max_corr = int("maxCorrectionBits", Some(0))?;
        if !(2..=8).contains(&size) {
            return Err(fail(format!("markersize {size} is not in 2..=8")));
        }
        let cells = (size * size) as usize;
        let mut codes = Vec::with_capacity(nmarkers as usize);
        for i in 0..nmarkers {
            let key = format!("marker_{i}");
            let (line, bits) = values
                .get(&key)
                .ok_or_else(|| fail(format!("no '{key}' entry (nmarkers is {nmarkers})")))?;
            if bits.len() != cells || !bits.bytes().all(|b| b == b'0' || b == b'1') {
                return Err(fail(format!(
                    "line {line}: {key} must be {cells} characters of 0 and 1, found '{bits}'"
                )));
            }
            codes.push(
                bits.bytes()
                    .fold(0u64, |acc, b| (acc << 1) | u64::from(b == b'1')),
            );
        }
        let name = path
            .file_stem()
            .map_or("custom".into(), |s| s.to_string_lossy().into_owned());
        Self::new(name, size, max_corr, codes).map_err(|e| fail(e.to_string()))
    }

    /// The dictionary's name (`6x6_250`, or a custom file's stem).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Cells per side of the inner code (without the black border).
    pub fn marker_size(&self) -> u32 {
        self.marker_size
    }

    /// OpenCV's `maxCorrectionBits`: bits the dictionary's spacing allows to correct.
    pub fn max_correction_bits(&self) -> u32 {
        self.max_correction_bits
    }

    /// Every marker's code, rotation 0 (see the module doc for the bit order).
    pub fn codes(&self) -> &[u64] {
        &self.codes
    }

    /// Number of markers.
    pub fn len(&self) -> usize {
        self.codes.len()
    }

    /// True for a dictionary without markers.
    pub fn is_empty(&self) -> bool {
        self.codes.is_empty()
    }

    /// The inner cells of marker `id`, row-major, `true` = white; `None` past the end.
    pub fn marker_bits(&self, id: u32) -> Option<Vec<bool>> {
        let code = *self.codes.get(id as usize)?;
        let cells = self.marker_size * self.marker_size;
        Some(
            (0..cells)
                .map(|k| code >> (cells - 1 - k) & 1 == 1)
                .collect(),
        )
    }

    /// Rotation `rotation` (0..4, OpenCV's order) of marker `id`'s code.
    pub fn rotated_code(&self, id: u32, rotation: u8) -> Option<u64> {
        self.rotations
            .get(id as usize)
            .map(|r| r[(rotation & 3) as usize])
    }

    /// Most cells detection corrects: `floor(max_correction_bits × rate)` (OpenCV's rule).
    pub fn correction_limit(&self, error_correction_rate: f64) -> u32 {
        (f64::from(self.max_correction_bits) * error_correction_rate).max(0.0) as u32
    }

    /// Identifies observed bits (same layout as the codes), trying all 4 rotations and
    /// accepting up to [`Dictionary::correction_limit`] wrong cells at OpenCV's default rate.
    pub fn identify(&self, bits: u64) -> Option<Identified> {
        let cells = self.marker_size * self.marker_size;
        let mask = if cells == 64 {
            u64::MAX
        } else {
            (1u64 << cells) - 1
        };
        let bits = bits & mask;
        // A cell is "not black" where the bit is 1 and "not white" where it is 0.
        self.identify_cells(
            bits,
            !bits & mask,
            self.correction_limit(DEFAULT_ERROR_CORRECTION_RATE),
        )
    }

    /// OpenCV's `Dictionary::identify` on cell masks: `not_black` has a 1 where a cell is not
    /// clearly black, `not_white` where it is not clearly white (an uncertain cell is in both and
    /// disagrees with every code). The first id (in dictionary order) whose best rotation is
    /// within `max_errors` wins, with the first rotation reaching that distance.
    pub fn identify_cells(
        &self,
        not_black: u64,
        not_white: u64,
        max_errors: u32,
    ) -> Option<Identified> {
        if not_black & not_white == 0 {
            if let Some(&(id, rotation)) = self.exact.get(&not_black) {
                // Codes of a dictionary are farther apart than twice the correction limit, so
                // an exact match is the only one within it; a custom dictionary with a
                // careless limit falls back to the scan below for an earlier id.
                if max_errors == 0 || self.unique_within(max_errors) {
                    return Some(Identified {
                        id,
                        rotation,
                        hamming: 0,
                    });
                }
            }
            if max_errors == 0 {
                return None;
            }
        }
        for (id, rots) in self.rotations.iter().enumerate() {
            let mut best = u32::MAX;
            let mut best_r = 0u8;
            for (r, &code) in rots.iter().enumerate() {
                // Error where the code is 0 and the cell is not black, or 1 and not white.
                let d = ((!code & not_black) | (code & not_white)).count_ones();
                if d < best {
                    best = d;
                    best_r = r as u8;
                    if d == 0 {
                        break;
                    }
                }
            }
            if best <= max_errors {
                return Some(Identified {
                    id: id as u32,
                    rotation: best_r,
                    hamming: best,
                });
            }
        }
        None
    }

    /// Fewest wrong cells of observed cell masks (as [`Dictionary::identify_cells`] takes them)
    /// against any code in any rotation.
    pub(crate) fn nearest_distance(&self, not_black: u64, not_white: u64) -> u32 {
        self.rotations
            .iter()
            .flatten()
            .map(|&code| ((!code & not_black) | (code & not_white)).count_ones())
            .min()
            .unwrap_or(u32::MAX)
    }

    /// True when no two codes (any rotations) lie within `2 × max_errors` of each other, by the
    /// dictionary's own promise (`max_correction_bits`).
    fn unique_within(&self, max_errors: u32) -> bool {
        max_errors <= self.max_correction_bits
    }
}

/// The 4 rotations of a code, OpenCV's order (`rot[row][col] = bits[col][n - 1 - row]`).
pub(crate) fn all_rotations(code: u64, n: u32) -> [u64; 4] {
    let mut out = [code; 4];
    for r in 1..4 {
        out[r] = rotate_once(out[r - 1], n);
    }
    out
}

fn rotate_once(code: u64, n: u32) -> u64 {
    let cells = n * n;
    let bit = |c: u64, row: u32, col: u32| c >> (cells - 1 - (row * n + col)) & 1;
    let mut out = 0u64;
    for row in 0..n {
        for col in 0..n {
            out = (out << 1) | bit(code, col, n - 1 - row);
        }
    }
    out
}

fn parse_num(s: &str) -> u32 {
    s.parse().expect("embedded number")
}

/// `4x4_50`-style key for any accepted spelling.
fn canonical_name(name: &str) -> Option<&'static str> {
    let lower = name.trim().to_ascii_lowercase();
    let bare = lower.strip_prefix("dict_").unwrap_or(&lower);
    let bare = match bare {
        "aruco_original" | "original" | "aruco" => "original",
        other => other,
    };
    PREDEFINED_NAMES.iter().copied().find(|n| *n == bare)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_predefined_dictionary_loads_with_opencv_sizes() {
        let expect = [
            ("4x4_50", 4, 50, 1),
            ("4x4_1000", 4, 1000, 0),
            ("5x5_250", 5, 250, 2),
            ("6x6_250", 6, 250, 5),
            ("6x6_1000", 6, 1000, 4),
            ("7x7_50", 7, 50, 9),
            ("original", 5, 1024, 1),
        ];
        for (name, size, len, corr) in expect {
            let d = Dictionary::predefined(name).unwrap();
            assert_eq!(
                (d.marker_size(), d.len(), d.max_correction_bits()),
                (size, len, corr),
                "{name}"
            );
        }
        for name in PREDEFINED_NAMES {
            assert!(Dictionary::predefined(name).is_ok(), "{name}");
        }
        assert_eq!(
            Dictionary::predefined("DICT_6X6_250").unwrap().name(),
            "6x6_250"
        );
        assert_eq!(
            Dictionary::predefined("DICT_ARUCO_ORIGINAL").unwrap().len(),
            1024
        );
        let err = Dictionary::predefined("9x9_3").unwrap_err().to_string();
        assert!(err.contains("9x9_3") && err.contains("6x6_250"), "{err}");
    }

    #[test]
    fn original_marker_1_has_opencv_bits() {
        // cv2.aruco.Dictionary.getBitsFromByteList(DICT_ARUCO_ORIGINAL.bytesList[1:2], 5)
        let d = Dictionary::predefined("original").unwrap();
        let bits: Vec<u8> = d
            .marker_bits(1)
            .unwrap()
            .iter()
            .map(|&b| u8::from(b))
            .collect();
        let want = [
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1, 1, 1,
        ];
        assert_eq!(bits, want);
    }

    #[test]
    fn identify_finds_every_rotation_and_corrects_errors() {
        let d = Dictionary::predefined("6x6_250").unwrap();
        for id in [0u32, 17, 249] {
            for r in 0..4u8 {
                let code = d.rotated_code(id, r).unwrap();
                assert_eq!(
                    d.identify(code),
                    Some(Identified {
                        id,
                        rotation: r,
                        hamming: 0
                    })
                );
                // limit = floor(5 * 0.6) = 3 flipped cells
                let noisy = code ^ 0b1001_0001;
                assert_eq!(
                    d.identify(noisy).map(|m| (m.id, m.rotation, m.hamming)),
                    Some((id, r, 3))
                );
                assert_eq!(d.identify(code ^ 0b1111_0000_0000_0000), None);
            }
        }
    }

    #[test]
    fn nearest_distance_counts_the_wrong_cells_of_the_best_code() {
        let d = Dictionary::predefined("4x4_50").unwrap();
        let mask = (1u64 << 16) - 1;
        let code = d.codes()[7];
        assert_eq!(d.nearest_distance(code, !code & mask), 0);
        // Two cells flipped, one cell uncertain (in both masks): three wrong.
        let bits = code ^ 0b101;
        let (not_black, not_white) = (bits | 1 << 9, (!bits & mask) | 1 << 9);
        assert_eq!(d.nearest_distance(not_black, not_white), 3);
    }

    #[test]
    fn rotation_four_times_is_identity() {
        let code = 0b1011_0010_0111_0001_1010_1100_0011_0110_1001u64;
        let r = all_rotations(code, 6);
        assert_eq!(rotate_once(r[3], 6), code);
        assert_ne!(r[1], code);
    }
}
