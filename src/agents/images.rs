//! Scene images: validated, downscaled to an edge limit and encoded before
//! they are sent, so that a bad file is named before any request is made.

use std::io::Cursor;
use std::path::Path;

use base64::Engine;
use image::{DynamicImage, ImageFormat, ImageReader};

use super::provider::ImageInput;
use super::{sha256_hex, AgentError};

/// The default longest edge, in pixels, of an image sent to a model.
pub const DEFAULT_MAX_EDGE: u32 = 1024;

/// Reads the image file at `path` within its size limit and decodes it:
/// the bytes, their format and the picture, or why it cannot be used, in
/// words for the user. The one reading of a scene image, so that what a
/// provider is sent and what a screen shows are refused alike (an empty, cut
/// or oversized file, a format not read).
pub fn read_image(path: &Path) -> Result<(Vec<u8>, ImageFormat, DynamicImage), String> {
    let bytes =
        crate::limits::read_file(path, crate::limits::MAX_IMAGE_FILE_BYTES, "an image file")
            .map_err(|err| err.to_string())?;
    if bytes.is_empty() {
        return Err("the file is empty (0 bytes): copy the image again".into());
    }
    let reader = ImageReader::new(Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|err| format!("cannot read it ({err})"))?;
    let format = reader
        .format()
        .ok_or("not an image this program reads: use JPEG, PNG, WebP or GIF")?;
    if format == ImageFormat::Jpeg && !jpeg_is_complete(&bytes) {
        return Err(
            "the JPEG file is truncated (its image data ends before the end-of-image marker): copy the image again".into(),
        );
    }
    let decoded = reader
        .decode()
        .map_err(|err| format!("not a valid {format:?} image ({err})"))?;
    if decoded.width() == 0 || decoded.height() == 0 {
        return Err("the image is empty (0 pixels)".into());
    }
    Ok((bytes, format, decoded))
}

/// Reads the image at `path` ([`read_image`]), and downscales it so that
/// neither edge exceeds `max_edge` (an image already small enough, in a
/// format providers accept, is sent as it is).
pub fn prepare_image(path: &Path, max_edge: u32) -> Result<ImageInput, AgentError> {
    let fail = |reason: String| AgentError::Image {
        path: path.to_path_buf(),
        reason,
    };
    let (bytes, format, decoded) = read_image(path).map_err(fail)?;
    let fits = decoded.width().max(decoded.height()) <= max_edge.max(1);
    let sendable = matches!(
        format,
        ImageFormat::Jpeg | ImageFormat::Png | ImageFormat::WebP | ImageFormat::Gif
    );
    let (bytes, format) = if fits && sendable {
        (bytes, format)
    } else {
        let scaled = if fits {
            decoded
        } else {
            decoded.resize(max_edge, max_edge, image::imageops::FilterType::Triangle)
        };
        let mut out = Vec::new();
        DynamicImage::ImageRgb8(scaled.to_rgb8())
            .write_to(&mut Cursor::new(&mut out), ImageFormat::Jpeg)
            .map_err(|err| fail(format!("cannot re-encode it ({err})")))?;
        (out, ImageFormat::Jpeg)
    };
    Ok(ImageInput {
        path: path.to_path_buf(),
        media_type: format.to_mime_type().to_string(),
        sha256: sha256_hex(&bytes),
        data_base64: base64::engine::general_purpose::STANDARD
            .encode(&bytes)
            .into(),
    })
}

/// Whether a JPEG's main image data reaches its end-of-image marker
/// (`FF D9`): the decoder fills a cut file with grey and says nothing, as
/// Pillow would not ("image file is truncated"). The segments before the
/// first scan are skipped by their lengths, so a thumbnail's markers inside
/// EXIF data do not count; entropy-coded data cannot hold `FF D9`.
pub fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let mut at = 2;
    while at + 4 <= bytes.len() {
        if bytes[at] != 0xff {
            return false;
        }
        let marker = bytes[at + 1];
        if marker == 0xff {
            at += 1;
            continue;
        }
        let length = usize::from(u16::from_be_bytes([bytes[at + 2], bytes[at + 3]]));
        if marker == 0xda {
            let scan = (at + 2 + length).min(bytes.len());
            return bytes[scan..].windows(2).any(|w| w == [0xff, 0xd9]);
        }
        at += 2 + length;
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_images_are_downscaled_and_bad_ones_named() {
        let dir = tempfile::tempdir().unwrap();
        let big = dir.path().join("big.png");
        image::RgbImage::from_pixel(300, 150, image::Rgb([10, 200, 30]))
            .save(&big)
            .unwrap();
        let sent = prepare_image(&big, 100).unwrap();
        assert_eq!(sent.media_type, "image/jpeg");
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(sent.data_base64.as_bytes())
            .unwrap();
        let back = image::load_from_memory(&bytes).unwrap();
        assert_eq!((back.width(), back.height()), (100, 50));

        let small = prepare_image(&big, 1000).unwrap();
        assert_eq!(small.media_type, "image/png");
        assert_eq!(small.sha256, sha256_hex(&std::fs::read(&big).unwrap()));

        let bad = dir.path().join("scene.jpg");
        std::fs::write(&bad, b"\xff\xd8\xff\xe0 not really a jpeg").unwrap();
        let err = prepare_image(&bad, 1000).unwrap_err().to_string();
        assert!(err.contains("scene.jpg"), "{err}");

        let photo = dir.path().join("photo.jpg");
        image::RgbImage::from_fn(64, 48, |x, y| image::Rgb([x as u8 * 3, y as u8 * 5, 90]))
            .save(&photo)
            .unwrap();
        assert!(prepare_image(&photo, 1000).is_ok());
        let whole = std::fs::read(&photo).unwrap();
        let cut = dir.path().join("cut.jpg");
        std::fs::write(&cut, &whole[..whole.len() * 2 / 3]).unwrap();
        let err = prepare_image(&cut, 1000).unwrap_err().to_string();
        assert!(err.contains("cut.jpg: the JPEG file is truncated"), "{err}");

        let empty = dir.path().join("empty.jpg");
        std::fs::write(&empty, b"").unwrap();
        let err = prepare_image(&empty, 1000).unwrap_err().to_string();
        assert!(err.contains("empty.jpg: the file is empty"), "{err}");
    }
}
