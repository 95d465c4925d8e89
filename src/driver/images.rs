//! The images stage: after checking, the images that `texture` calls name
//! are found and loaded through the options' texture manager. Checking
//! records each as a path ([`check::ImageUse`]); this stage fills in its
//! image, so checking does no I/O and knows nothing of files.

use crate::check;
use crate::diag::Diagnostic;
use crate::load::{LoadOptions, find_file, searched};
use crate::texture::MipMap;
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
                use_.image = Some(image)
            }
            Err(e) => {
                diags.push(Diagnostic::error(use_.span, format!("cannot read the image `{}`: {e}", found.display())))
            }
        }
    }
    diags
}
