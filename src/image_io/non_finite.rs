//! Texels that are not numbers (NaN or infinite), found when an image is
//! loaded and replaced by 0 before anything is made of it, as OpenImageIO's
//! `maketx --fixnan black` does: one NaN would otherwise spread through
//! every mip level above it and into the samples that touch it, and one
//! infinite texel makes an environment's sampling distribution infinite
//! (the scene then has "no light"). The loader reports what was replaced.

use std::fmt;

/// What [`replace_non_finite`] replaced: how many values, and the first
/// (in row order): its texel, channel and value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonFiniteTexels {
    /// Channel values replaced (a texel with NaN in R and G counts twice).
    pub count: u64,
    pub x: u32,
    pub y: u32,
    /// 0 to 3: R, G, B, A.
    pub channel: usize,
    pub value: f32,
}

impl fmt::Display for NonFiniteTexels {
    /// `3 values that are not numbers (NaN or infinite), the first +inf
    /// in channel R of texel (12, 7)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let channel = ["R", "G", "B", "A"].get(self.channel).copied().unwrap_or("?");
        let value = if self.value.is_nan() {
            "NaN"
        } else if self.value > 0.0 {
            "+inf"
        } else {
            "-inf"
        };
        let (values, first) = if self.count == 1 { ("value", "it is") } else { ("values", "the first is") };
        write!(
            f,
            "{} {values} that {} not a number (NaN or infinite): {first} {value} in channel {channel} of texel ({}, {})",
            self.count,
            if self.count == 1 { "is" } else { "are" },
            self.x,
            self.y
        )
    }
}

impl NonFiniteTexels {
    /// The warning a loader gives: `{image} has 1 value that is not a
    /// number (NaN or infinite): it is +inf in channel R of texel (3, 2);
    /// it is replaced by 0`.
    pub fn warning(&self, image: &str) -> String {
        format!("{image} has {self}; {} replaced by 0", if self.count == 1 { "it is" } else { "they are" })
    }
}

/// Replaces every NaN or infinite value of `texels` (rows of `width`
/// texels of `C` channels) by 0; `None` when there was none.
pub fn replace_non_finite<const C: usize>(texels: &mut [[f32; C]], width: u32) -> Option<NonFiniteTexels> {
    let mut found: Option<NonFiniteTexels> = None;
    for (k, texel) in texels.iter_mut().enumerate() {
        // The common case, a clean texel, is one comparison per channel.
        if texel.iter().all(|v| v.is_finite()) {
            continue;
        }
        for (channel, v) in texel.iter_mut().enumerate() {
            if v.is_finite() {
                continue;
            }
            match &mut found {
                Some(f) => f.count += 1,
                None => {
                    let width = width.max(1) as usize;
                    let (x, y) = ((k % width) as u32, (k / width) as u32);
                    found = Some(NonFiniteTexels { count: 1, x, y, channel, value: *v });
                }
            }
            *v = 0.0;
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_values_are_replaced_by_zero_and_the_first_is_named() {
        let mut clean = vec![[0.5f32, 1.0, f32::MAX, 1.0]; 6];
        assert_eq!(replace_non_finite(&mut clean, 3), None);
        assert_eq!(clean[0], [0.5, 1.0, f32::MAX, 1.0]);
        let mut texels = vec![[0.25f32; 4]; 6];
        texels[4][2] = f32::INFINITY;
        texels[5][0] = f32::NAN;
        texels[5][3] = f32::NEG_INFINITY;
        let found = replace_non_finite(&mut texels, 3).unwrap();
        assert_eq!((found.count, found.x, found.y, found.channel), (3, 1, 1, 2));
        assert!(texels.iter().flatten().all(|v| v.is_finite()));
        assert_eq!((texels[4][2], texels[5][0], texels[5][3], texels[5][1]), (0.0, 0.0, 0.0, 0.25));
        let words = found.to_string();
        assert!(words.contains("3 values") && words.contains("+inf in channel B of texel (1, 1)"), "{words}");
        let mut rgb = vec![[1.0f32, f32::NAN, 0.0]];
        let one = replace_non_finite(&mut rgb, 1).unwrap();
        assert!(one.to_string().starts_with("1 value that is not a number"), "{one}");
        assert!(one.to_string().contains("NaN in channel G of texel (0, 0)"), "{one}");
    }
}
