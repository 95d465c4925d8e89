//! The layers of a rendered image as 8-bit pictures people can look at
//! (`tslc view`): radiance and albedo sRGB-encoded, normals as a normal
//! map encodes them, depth as nearness, objects as distinct colours.

use super::{NO_OBJECT, RenderedImage, srgb_encode};

/// A layer of a rendered image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayerName {
    /// `R`, `G`, `B`: linear radiance.
    Color,
    Albedo,
    Normal,
    /// `Z`: the distance from the camera.
    Depth,
    Object,
}

impl LayerName {
    pub const ALL: [LayerName; 5] =
        [LayerName::Color, LayerName::Albedo, LayerName::Normal, LayerName::Depth, LayerName::Object];

    pub fn name(self) -> &'static str {
        match self {
            LayerName::Color => "color",
            LayerName::Albedo => "albedo",
            LayerName::Normal => "normal",
            LayerName::Depth => "depth",
            LayerName::Object => "object",
        }
    }

    /// The layer called `name` (`Z` is depth, as the EXR channel).
    pub fn parse(name: &str) -> Option<LayerName> {
        let name = if name == "Z" { "depth" } else { name };
        LayerName::ALL.into_iter().find(|l| l.name() == name)
    }
}

/// The pixels of `layer` as 8-bit RGB, row by row: radiance and albedo
/// clamped and sRGB-encoded; a normal `n` as `(n + 1) / 2` (as tangent
/// normal maps store them); depth as nearness (the nearest hit white, the
/// farthest dark grey, no hit black); each object a colour of its own
/// (none black). An error when the image has no such layer (rendered
/// without `--aov`).
pub fn layer_rgb8(image: &RenderedImage, layer: LayerName) -> Result<Vec<[u8; 3]>, String> {
    let missing =
        || format!("the image has no {} layer (render with --aov for albedo, normal, depth and object)", layer.name());
    Ok(match layer {
        LayerName::Color => image.color.iter().map(|p| p.map(srgb_encode)).collect(),
        LayerName::Albedo => image.albedo.as_ref().ok_or_else(missing)?.iter().map(|p| p.map(srgb_encode)).collect(),
        LayerName::Normal => {
            let unit = |x: f32| if x.is_finite() { ((x.clamp(-1.0, 1.0) + 1.0) * 127.5).round() as u8 } else { 0 };
            image.normal.as_ref().ok_or_else(missing)?.iter().map(|n| n.map(unit)).collect()
        }
        LayerName::Depth => {
            let depth = image.depth.as_ref().ok_or_else(missing)?;
            let hits = || depth.iter().copied().filter(|d| d.is_finite() && *d >= 0.0);
            let (near, far) = hits().fold((f32::INFINITY, 0.0f32), |(lo, hi), d| (lo.min(d), hi.max(d)));
            let span = (far - near).max(f32::MIN_POSITIVE);
            depth
                .iter()
                .map(|&d| {
                    let v = if d.is_finite() && d >= 0.0 { 255.0 - 200.0 * (d - near) / span } else { 0.0 };
                    [v.round() as u8; 3]
                })
                .collect()
        }
        LayerName::Object => image
            .object
            .as_ref()
            .ok_or_else(missing)?
            .iter()
            .map(|&k| if k == NO_OBJECT { [0; 3] } else { object_colour(k) })
            .collect(),
    })
}

/// A bright colour for object `k`, far from its neighbours' (golden-ratio
/// hue steps).
fn object_colour(k: i32) -> [u8; 3] {
    let hue = (k as f32 * 0.618_034).fract() * 6.0;
    let x = 1.0 - (hue % 2.0 - 1.0).abs();
    let (r, g, b) = match hue as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r, g, b].map(|c: f32| (55.0 + 200.0 * c).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image() -> RenderedImage {
        RenderedImage {
            full_width: 2,
            full_height: 1,
            x0: 0,
            y0: 0,
            width: 2,
            height: 1,
            color: vec![[0.0, 0.5, 1.0], [2.0, -1.0, f32::NAN]],
            albedo: None,
            normal: Some(vec![[0.0, 0.0, 1.0], [-1.0, 1.0, 0.0]]),
            depth: Some(vec![2.0, f32::INFINITY]),
            object: Some(vec![3, NO_OBJECT]),
        }
    }

    #[test]
    fn each_layer_maps_to_what_people_expect_to_see() {
        let img = image();
        assert_eq!(layer_rgb8(&img, LayerName::Color).unwrap()[0], [0, 188, 255]);
        assert_eq!(layer_rgb8(&img, LayerName::Normal).unwrap(), [[128, 128, 255], [0, 255, 128]]);
        assert_eq!(layer_rgb8(&img, LayerName::Depth).unwrap(), [[255; 3], [0; 3]]);
        let objects = layer_rgb8(&img, LayerName::Object).unwrap();
        assert_ne!(objects[0], [0; 3]);
        assert_eq!(objects[1], [0; 3]);
        let err = layer_rgb8(&img, LayerName::Albedo).unwrap_err();
        assert!(err.contains("no albedo layer") && err.contains("--aov"), "{err}");
        assert_eq!(LayerName::parse("Z"), Some(LayerName::Depth));
        assert_eq!(LayerName::parse("albedo"), Some(LayerName::Albedo));
        assert_eq!(LayerName::parse("alpha"), None);
        // Distinct objects, distinct colours.
        let colours: std::collections::HashSet<[u8; 3]> = (0..12).map(object_colour).collect();
        assert_eq!(colours.len(), 12);
    }
}
