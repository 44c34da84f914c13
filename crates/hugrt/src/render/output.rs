//! Writing images: the format chosen by the file's name, as scenes are written by theirs
//! ([`crate::scene::write::SceneFormat`]).

use crate::Error;
use std::path::Path;

/// The image formats hugrt writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB PNG.
    Png,
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
            return Err(bad("is a directory; give a file name ending in .png"));
        }
        match path.extension() {
            Some(e) if e.eq_ignore_ascii_case("png") => Ok(ImageFormat::Png),
            _ => Err(bad("hugrt writes PNG images; give a name ending in .png")),
        }
    }
}

/// Writes `image` to `path` in the format its name says ([`ImageFormat::for_path`]).
pub fn save_image(image: &image::RgbImage, path: &Path) -> Result<(), Error> {
    match ImageFormat::for_path(path)? {
        ImageFormat::Png => image
            .save_with_format(path, image::ImageFormat::Png)
            .map_err(|e| match e {
                image::ImageError::IoError(io) => Error::write(path, io),
                other => Error::write(path, std::io::Error::other(other)),
            }),
    }
}
