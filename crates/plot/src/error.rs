//! Errors and the atomic PNG writer.

use std::path::{Path, PathBuf};

use tiny_skia::Pixmap;

/// What can go wrong writing a plot.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file (or its temporary sibling) could not be written, e.g. the folder is
    /// missing or not writable.
    #[error("cannot write plot {}: {source}", path.display())]
    Io {
        /// The PNG path asked for.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// PNG encoding failed.
    #[error("cannot encode plot {} as PNG: {message}", path.display())]
    Encode {
        /// The PNG path asked for.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

/// Encodes a pixmap as PNG bytes. Opaque pixmaps (every plot) are written as 8-bit RGB,
/// others as RGBA (demultiplied), with fast compression: PNG encoding would otherwise
/// cost more than drawing.
pub fn encode_png(pixmap: &Pixmap) -> Result<Vec<u8>, png::EncodingError> {
    let opaque = pixmap.pixels().iter().all(|p| p.alpha() == 255);
    let (color, data): (png::ColorType, Vec<u8>) = if opaque {
        let rgb = pixmap
            .pixels()
            .iter()
            .flat_map(|p| [p.red(), p.green(), p.blue()])
            .collect();
        (png::ColorType::Rgb, rgb)
    } else {
        let rgba = pixmap
            .pixels()
            .iter()
            .flat_map(|p| {
                let c = p.demultiply();
                [c.red(), c.green(), c.blue(), c.alpha()]
            })
            .collect();
        (png::ColorType::Rgba, rgba)
    };
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, pixmap.width(), pixmap.height());
    enc.set_color(color);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header()?;
    writer.write_image_data(&data)?;
    writer.finish()?;
    Ok(out)
}

/// Writes `pixmap` as a PNG at `path`, atomically: the bytes go to a temporary file in
/// the same folder (`.NAME.tmpPID`), which is synced and then renamed over `path`, so a
/// reader never sees a partial PNG under the final name. On error the temporary file is
/// removed and the error names `path`.
pub fn save_png(pixmap: &Pixmap, path: &Path) -> Result<(), PlotError> {
    let bytes = encode_png(pixmap).map_err(|e| PlotError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    slothsim_scene::write_atomically(path, &bytes).map_err(|source| PlotError::Io {
        path: path.to_path_buf(),
        source,
    })
}
