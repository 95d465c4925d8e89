//! What made an image, in its EXR header: the scene's content hash, tslc's
//! version, the render settings, the frame and the tile. `tslc render`
//! writes it into every EXR, `tslc merge` refuses parts that disagree on
//! it, and `tslc info` prints it. The resolution and the window rendered
//! are the header's own display and data windows.
//!
//! Invariant: a header is the same bytes for the same attributes. The exr
//! crate writes custom attributes in the order of a `HashMap` (random per
//! process), so [`sort_header_attributes`] puts every attribute of a
//! written file in name order; OpenEXR leaves the order free.

use std::collections::BTreeMap;
use std::fmt;

/// One attribute's value.
#[derive(Debug, Clone, PartialEq)]
pub enum AttributeValue {
    Int(i32),
    Float(f32),
    Text(String),
}

impl fmt::Display for AttributeValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AttributeValue::Int(x) => write!(f, "{x}"),
            AttributeValue::Float(x) => write!(f, "{x}"),
            AttributeValue::Text(s) => f.write_str(s),
        }
    }
}

impl AttributeValue {
    /// The value as JSON: a number or a string.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            AttributeValue::Int(x) => (*x).into(),
            AttributeValue::Float(x) => {
                serde_json::Number::from_f64(f64::from(*x)).map_or(serde_json::Value::Null, Into::into)
            }
            AttributeValue::Text(s) => s.clone().into(),
        }
    }
}

/// The standard attribute naming the program that wrote the file.
pub const SOFTWARE: &str = "software";
/// The attributes TSL writes, with what each means (for messages and
/// `tslc info`), in the order `tslc info` prints them.
pub const ATTRIBUTES: &[(&str, &str)] = &[
    (SOFTWARE, "the program that rendered it"),
    ("tsl:version", "tslc's version"),
    ("tsl:sceneHash", "BLAKE3 (256-bit) of the scene's sources, imports, textures, meshes and environment"),
    ("tsl:scene", "the scene file, as named on the command line"),
    ("tsl:spp", "samples per pixel"),
    ("tsl:seed", "the random seed"),
    ("tsl:maxDepth", "the maximum path depth"),
    ("tsl:integrator", "the integrator"),
    ("tsl:lightSampling", "how lights are sampled"),
    ("tsl:colorModel", "the color model"),
    ("tsl:frame", "the frame"),
    ("tsl:time", "the frame's time in seconds"),
    ("tsl:tile", "the tile's number, I of --tile I/N"),
    ("tsl:tiles", "the number of tiles, N of --tile I/N"),
];

/// Attributes that differ between the parts of one image; every other
/// attribute must agree for `merge`.
pub const PER_PART: &[&str] = &["tsl:tile", "tsl:scene"];

/// What an attribute means, for messages.
pub fn meaning(name: &str) -> Option<&'static str> {
    ATTRIBUTES.iter().find(|a| a.0 == name).map(|a| a.1)
}

/// An image's provenance: header attributes by name (TSL's are `tsl:*`;
/// `software` is OpenEXR's own). Attributes of other types that a file
/// may carry are not kept.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Metadata {
    pub attributes: BTreeMap<String, AttributeValue>,
}

impl Metadata {
    pub fn set(&mut self, name: &str, value: AttributeValue) -> &mut Self {
        self.attributes.insert(name.to_string(), value);
        self
    }

    pub fn set_int(&mut self, name: &str, value: i32) -> &mut Self {
        self.set(name, AttributeValue::Int(value))
    }

    pub fn set_float(&mut self, name: &str, value: f32) -> &mut Self {
        self.set(name, AttributeValue::Float(value))
    }

    pub fn set_text(&mut self, name: &str, value: impl Into<String>) -> &mut Self {
        self.set(name, AttributeValue::Text(value.into()))
    }

    pub fn get(&self, name: &str) -> Option<&AttributeValue> {
        self.attributes.get(name)
    }

    pub fn int(&self, name: &str) -> Option<i32> {
        match self.get(name)? {
            AttributeValue::Int(x) => Some(*x),
            _ => None,
        }
    }

    /// Whether any attribute is TSL's: the file was written by `tslc`.
    pub fn is_tsl(&self) -> bool {
        self.attributes.keys().any(|k| k.starts_with("tsl:"))
    }

    /// The attributes in `tslc info`'s order: TSL's known ones first, then
    /// the others by name.
    pub fn ordered(&self) -> Vec<(&str, &AttributeValue)> {
        let known = ATTRIBUTES.iter().filter_map(|(n, _)| self.attributes.get_key_value(*n));
        let other = self.attributes.iter().filter(|(k, _)| meaning(k).is_none());
        known.chain(other).map(|(k, v)| (k.as_str(), v)).collect()
    }

    /// The exr crate's form: the software name apart, the rest as custom
    /// attributes. Text that is not Latin-1 (the EXR text encoding) has
    /// `?` for the characters it cannot hold.
    pub(super) fn to_exr(
        &self,
    ) -> (Option<exr::meta::attribute::Text>, Vec<(exr::meta::attribute::Text, exr::meta::attribute::AttributeValue)>)
    {
        use exr::meta::attribute::{AttributeValue as A, Text};
        let text = |s: &str| {
            let latin1: String = s.chars().map(|c| if (c as u32) < 256 { c } else { '?' }).collect();
            Text::new_or_none(&latin1).unwrap_or_else(|| Text::from("?"))
        };
        let mut software = None;
        let mut other = Vec::new();
        for (name, value) in &self.attributes {
            if name == SOFTWARE {
                software = Some(text(&value.to_string()));
                continue;
            }
            let value = match value {
                AttributeValue::Int(x) => A::I32(*x),
                AttributeValue::Float(x) => A::F32(*x),
                AttributeValue::Text(s) => A::Text(text(s)),
            };
            other.push((text(name), value));
        }
        (software, other)
    }

    /// What a header holds, as far as metadata goes.
    pub(super) fn from_exr(
        layer: &exr::meta::header::LayerAttributes,
        image: &exr::meta::header::ImageAttributes,
    ) -> Metadata {
        use exr::meta::attribute::AttributeValue as A;
        let mut out = Metadata::default();
        if let Some(s) = &layer.software_name {
            out.set_text(SOFTWARE, s.to_string());
        }
        let attributes = layer.other.iter().chain(&image.other);
        for (name, value) in attributes {
            let value = match value {
                A::I32(x) => AttributeValue::Int(*x),
                A::F32(x) => AttributeValue::Float(*x),
                A::Text(t) => AttributeValue::Text(t.to_string()),
                _ => continue,
            };
            out.attributes.insert(name.to_string(), value);
        }
        out
    }
}

/// The most header bytes [`sort_header_attributes_of`] reads: TSL's
/// headers are well under a kilobyte.
const MAX_HEADER_BYTES: u64 = 1 << 16;

/// [`sort_header_attributes`] on the open file just written, rewriting
/// only its header.
pub(super) fn sort_header_attributes_of(file: &mut std::fs::File) -> Result<(), String> {
    use std::io::{Read, Seek, Write};
    file.rewind().map_err(|e| e.to_string())?;
    let mut head = Vec::new();
    (&mut *file).take(MAX_HEADER_BYTES).read_to_end(&mut head).map_err(|e| e.to_string())?;
    let end = sort_header_attributes(&mut head)?;
    file.seek(std::io::SeekFrom::Start(0)).map_err(|e| e.to_string())?;
    file.write_all(&head[..end]).map_err(|e| e.to_string())
}

/// Puts the attributes of a single-part OpenEXR file's header in byte
/// order of their names, in place: the same attributes are then the same
/// bytes, whatever order the encoder wrote them in. The header keeps its
/// length, so the offsets after it stay right. Returns where the header
/// ends.
pub(super) fn sort_header_attributes(bytes: &mut [u8]) -> Result<usize, String> {
    let bad = || "not a single-part OpenEXR header".to_string();
    // Magic number, then the version field; multi-part files (bit 12)
    // have several headers and are not written here.
    if bytes.len() < 8 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] || bytes[5] & 0x10 != 0 {
        return Err(bad());
    }
    let start = 8;
    let mut pos = start;
    let mut attributes: Vec<(usize, usize)> = Vec::new();
    let c_string_end = |from: usize| bytes[from..].iter().position(|&b| b == 0).map(|k| from + k);
    loop {
        let name_end = c_string_end(pos).ok_or_else(bad)?;
        if name_end == pos {
            break; // the empty name ends the header
        }
        let type_end = c_string_end(name_end + 1).ok_or_else(bad)?;
        let size_at = type_end + 1;
        let size = bytes.get(size_at..size_at + 4).ok_or_else(bad)?;
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let end = size_at + 4 + usize::try_from(size).map_err(|_| bad())?;
        if end > bytes.len() {
            return Err(bad());
        }
        attributes.push((pos, end));
        pos = end;
    }
    let name = |&(a, _): &(usize, usize)| &bytes[a..c_string_end(a).unwrap_or(a)];
    let mut sorted = attributes.clone();
    sorted.sort_by(|x, y| name(x).cmp(name(y)));
    let reordered: Vec<u8> = sorted.iter().flat_map(|&(a, b)| bytes[a..b].iter().copied()).collect();
    bytes[start..start + reordered.len()].copy_from_slice(&reordered);
    Ok(pos)
}
