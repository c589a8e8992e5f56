//! What the tests on the real photos share: where `../shared/data/aruco_real` is, its gold and
//! the dictionary each photo's gold names. The photos stay in the shared folder (their licence
//! and size keep them out of the repository).

use markers::Dictionary;
use serde_json::Value;
use std::path::PathBuf;

const DATA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/aruco_real"
);

/// A file of the shared photo folder.
pub fn data(name: &str) -> PathBuf {
    PathBuf::from(DATA).join(name)
}

/// `gold.json`, parsed.
pub fn gold() -> Value {
    let text = std::fs::read_to_string(data("gold.json")).expect("gold.json");
    serde_json::from_str(&text).expect("gold.json parses")
}

/// The dictionary a `gold.json` or `opencv_reference.json` entry names.
pub fn dictionary_for(image: &Value) -> Dictionary {
    let name = image["dictionary"].as_str().unwrap();
    if name.contains("tutorial_dict.yml") {
        Dictionary::from_opencv_yaml(data("tutorial_dict.yml")).unwrap()
    } else {
        Dictionary::predefined(name).unwrap()
    }
}
