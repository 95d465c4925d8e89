//! The images stage: after checking, the images that `texture` calls name
//! are found and loaded through the options' texture manager. Checking
//! records each as a path ([`check::ImageUse`]); this stage fills in its
//! image, so checking does no I/O and knows nothing of files. A UDIM tile
//! set's directory is listed here and its tiles recorded; their pixels
//! are read on first lookup ([`crate::texture::UdimSet`]).

use crate::check;
use crate::diag::{Diagnostic, Span};
use crate::load::{LoadOptions, find_file, find_where, searched};
use crate::texture::{FIRST_UDIM_TILE, LAST_UDIM_TILE, MipMap, TextureImage, UdimPattern, UdimSet, is_udim_pattern};
use std::path::Path;
use std::sync::Arc;

/// Loads the images a checked program's `texture` calls name, through the
/// options' texture manager. A path is looked up relative to the file that
/// names it, then in the import directories. Each failure is an error at
/// the string literal; an image with values that are not numbers (replaced
/// by 0 when it was loaded) is a warning at the first literal naming it.
pub(crate) fn load_images(program: &mut check::Program, options: &LoadOptions) -> Vec<Diagnostic> {
    let mut diags = Vec::new();
    let mut warned: Vec<Arc<MipMap>> = Vec::new();
    for use_ in &mut program.images {
        let file = program.loaded.sources.name(use_.span.file);
        let base = Path::new(file).parent();
        if is_udim_pattern(&use_.path) {
            use_.image = open_tile_set(use_, base, options, &mut diags).map(|set| TextureImage::Udim(Arc::new(set)));
            continue;
        }
        let Some(found) = find_file(base, &use_.path, &options.import_paths) else {
            diags.push(
                Diagnostic::error(use_.span, format!("cannot find the image `{}`", use_.path))
                    .with_help(format!("searched {}; add a directory with -I", searched(base, &options.import_paths))),
            );
            continue;
        };
        match options.textures.load(&found, use_.encoding) {
            Ok(image) => {
                // Once per image, at the first literal naming it.
                if let Some(replaced) = image.non_finite.filter(|_| !warned.iter().any(|w| Arc::ptr_eq(w, &image))) {
                    let what = format!("the image `{}`", found.display());
                    diags.push(Diagnostic::warning(use_.span, replaced.warning(&what)));
                    warned.push(image.clone());
                }
                use_.image = Some(TextureImage::Single(image))
            }
            Err(e) => {
                diags.push(Diagnostic::error(use_.span, format!("cannot read the image `{}`: {e}", found.display())))
            }
        }
    }
    diags
}

/// The tile set `use_` names: its pattern's directory found as an image
/// is (next to the file naming it, then in the import directories), the
/// first place with at least one tile. No tile anywhere is an error at the
/// literal naming the pattern and the directories searched; files off the
/// tile grid are a warning (they are left out).
fn open_tile_set(
    use_: &check::ImageUse,
    base: Option<&Path>,
    options: &LoadOptions,
    diags: &mut Vec<Diagnostic>,
) -> Option<UdimSet> {
    let error = |span: Span, message: String| Diagnostic::error(span, message);
    let pattern = match UdimPattern::parse(&use_.path) {
        Ok(pattern) => pattern,
        Err(e) => {
            diags.push(error(use_.span, format!("`{}`: {e}", use_.path)));
            return None;
        }
    };
    let dir = pattern.dir.to_string_lossy().into_owned();
    let mut opened: Result<Option<UdimSet>, String> = Ok(None);
    find_where(base, &dir, &options.import_paths, |place| {
        opened = UdimSet::open(place, &pattern, use_.encoding, options.textures.clone());
        !matches!(opened, Ok(None))
    });
    let set = match opened {
        Ok(Some(set)) => set,
        Ok(None) => {
            let example = [FIRST_UDIM_TILE, FIRST_UDIM_TILE + 1]
                .map(|n| format!("`{}`", pattern.dir.join(pattern.file_name(n)).display()));
            diags.push(error(use_.span, format!("no tile of the UDIM set `{}` exists", use_.path)).with_help(format!(
                "searched {} for {}, ... (tile 1001 + u + 10 v, numbered {FIRST_UDIM_TILE} to {LAST_UDIM_TILE})",
                searched(base, &options.import_paths),
                example.join(", ")
            )));
            return None;
        }
        Err(e) => {
            diags.push(error(use_.span, format!("cannot read the UDIM set `{}`: {e}", use_.path)));
            return None;
        }
    };
    for path in &set.off_grid {
        diags.push(
            Diagnostic::warning(
                use_.span,
                format!("the UDIM tile `{}` is off the tile grid and left out", path.display()),
            )
            .with_help(format!(
                "tiles are numbered {FIRST_UDIM_TILE} to {LAST_UDIM_TILE}: 1001 + u + 10 v for u in 0..10"
            )),
        );
    }
    Some(set)
}
