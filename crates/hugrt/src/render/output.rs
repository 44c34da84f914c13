//! Writing images: the format chosen by the file's name, as scenes are written by theirs
//! ([`crate::scene::write::SceneFormat`]).

use super::Rendered;
use crate::Error;
use std::path::Path;

/// The image formats hugrt writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit PNG: each channel clamped to `[0, 1]` and quantised.
    Png,
    /// OpenEXR with 32-bit float R, G, B channels: the radiance before clamping.
    Exr,
}

impl ImageFormat {
    /// The format of `path` by its extension (`.png`, any case); an error for a folder or
    /// any other name, so that a rendering is not lost after it has been made.
    pub fn for_path(path: &Path) -> Result<ImageFormat, Error> {
        let bad = |reason: &str| Error::Format {
            path: path.to_path_buf(),
            reason: reason.into(),
        };
        if path.is_dir() {
            return Err(bad(
                "is a directory; give a file name ending in .png or .exr",
            ));
        }
        match path.extension() {
            Some(e) if e.eq_ignore_ascii_case("png") => Ok(ImageFormat::Png),
            Some(e) if e.eq_ignore_ascii_case("exr") => Ok(ImageFormat::Exr),
            _ => Err(bad(
                "hugrt writes PNG and OpenEXR images; give a name ending in .png or .exr",
            )),
        }
    }
}

/// Writes a rendering to `path` in the format its name says ([`ImageFormat::for_path`]): the
/// 8-bit image as PNG, or the float radiance as OpenEXR.
pub fn save_image(rendered: &Rendered, path: &Path) -> Result<(), Error> {
    let image = &rendered.image;
    match ImageFormat::for_path(path)? {
        ImageFormat::Png => image
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| match e {
                image::ImageError::IoError(io) => Error::write(path, io),
                other => Error::write(path, std::io::Error::other(other)),
            }),
        ImageFormat::Exr => {
            let w = image.width() as usize;
            let radiance = &rendered.radiance;
            exr::prelude::write_rgb_file(path, w, image.height() as usize, |x, y| {
                let c = radiance[y * w + x];
                (c.x, c.y, c.z)
            })
            .map_err(|e| match e {
                exr::error::Error::Io(io) => Error::write(path, io),
                other => Error::write(path, std::io::Error::other(other.to_string())),
            })
        }
    }
}
