//! What the renderer draws into and writes out: an RGB [`Image`] (PNG in and out), an
//! animated GIF ([`GifWriter`]) and the errors of both ([`RenderError`]).

use std::fmt;
use std::path::{Path, PathBuf};

/// An 8-bit RGB image: what [`Renderer`](super::Renderer) draws (see its example).
///
/// # Examples
///
/// ```
/// use rapier_sph::render::Image;
///
/// let mut image = Image { width: 4, height: 2, rgb: vec![0; 4 * 2 * 3] };
/// image.rgb[3 * (4 + 2)] = 255; // row 1, column 2: red
/// assert_eq!(image.pixel(2, 1), [255, 0, 0]);
/// let path = std::env::temp_dir().join(format!("rapier_sph_doc_{}.png", std::process::id()));
/// image.save_png(&path)?;
/// assert_eq!(Image::load_png(&path)?, image);
/// std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width (pixels).
    pub width: u32,
    /// Height (pixels).
    pub height: u32,
    /// Row-major RGB bytes, top row first (`3 · width · height`).
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour of one pixel.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// Writes the image as PNG.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be created or written.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), RenderError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| RenderError::io(path, e))?;
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc
            .write_header()
            .map_err(|e| RenderError::encode(path, e))?;
        w.write_image_data(&self.rgb)
            .map_err(|e| RenderError::encode(path, e))?;
        w.finish().map_err(|e| RenderError::encode(path, e))
    }

    /// Reads an 8-bit RGB or RGBA PNG (alpha is dropped), e.g. to check a written frame.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be read or is not such a PNG.
    pub fn load_png(path: impl AsRef<Path>) -> Result<Image, RenderError> {
        let path = path.as_ref();
        let file = std::fs::File::open(path).map_err(|e| RenderError::io(path, e))?;
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .map_err(|e| RenderError::encode(path, e))?;
        let size = reader
            .output_buffer_size()
            .ok_or_else(|| RenderError::encode(path, "image too large"))?;
        let mut buf = vec![0; size];
        let info = reader
            .next_frame(&mut buf)
            .map_err(|e| RenderError::encode(path, e))?;
        let channels = match (info.color_type, info.bit_depth) {
            (png::ColorType::Rgb, png::BitDepth::Eight) => 3,
            (png::ColorType::Rgba, png::BitDepth::Eight) => 4,
            other => {
                return Err(RenderError::encode(
                    path,
                    format!("unsupported PNG layout {other:?}"),
                ));
            }
        };
        let rgb = buf[..info.buffer_size()]
            .chunks_exact(channels)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        Ok(Image {
            width: info.width,
            height: info.height,
            rgb,
        })
    }
}

/// Errors of writing pictures.
#[derive(Debug)]
#[non_exhaustive]
pub enum RenderError {
    /// The file could not be created or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The encoder refused the image.
    Encode {
        /// The file.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

impl RenderError {
    pub(super) fn io(path: &Path, source: std::io::Error) -> Self {
        RenderError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
    fn encode(path: &Path, message: impl fmt::Display) -> Self {
        RenderError::Encode {
            path: path.to_path_buf(),
            message: message.to_string(),
        }
    }
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            RenderError::Encode { path, message } => {
                write!(f, "{}: encoding failed: {message}", path.display())
            }
        }
    }
}

impl std::error::Error for RenderError {}

/// Writes an animated GIF frame by frame (each frame is quantised to its own 256-colour
/// palette by the `gif` crate's NeuQuant).
///
/// # Examples
///
/// ```
/// use rapier_sph::prelude::*;
/// use rapier_sph::render::{Camera, FluidStyle, GifWriter, RenderOptions, Renderer};
///
/// let mut world = FluidWorld::new();
/// let mut water = Fluid::new(FluidParamsBuilder::water(0.05))?;
/// water.add_block(Vector::ZERO, Vector::splat(0.3))?;
/// world.fluids.insert(water);
/// let options = RenderOptions { width: 48, height: 27, ..Default::default() };
/// let mut renderer = Renderer::new(RenderOptions { style: FluidStyle::Spheres, ..options });
/// let camera = Camera::framing(Vector::ZERO, Vector::splat(0.3), 30.0, 25.0);
/// let path = std::env::temp_dir().join(format!("rapier_sph_doc_{}.gif", std::process::id()));
/// // Frames of the renderer's size, 4 hundredths of a second each (25 frames per second).
/// let mut gif = GifWriter::create(&path, 48, 27, 4)?;
/// for _ in 0..3 {
///     world.step()?;
///     gif.add_frame(&renderer.render_world(&camera, &world, None))?;
/// }
/// gif.finish()?;
/// assert!(std::fs::metadata(&path)?.len() > 0);
/// std::fs::remove_file(&path)?;
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct GifWriter {
    encoder: gif::Encoder<std::io::BufWriter<std::fs::File>>,
    path: PathBuf,
    width: u16,
    height: u16,
    delay_cs: u16,
}

impl GifWriter {
    /// Creates `path` for frames of `width × height` pixels shown `delay_cs` hundredths of a
    /// second each, looping forever.
    ///
    /// # Errors
    ///
    /// [`RenderError`] naming the path when the file cannot be created.
    pub fn create(
        path: impl AsRef<Path>,
        width: u32,
        height: u32,
        delay_cs: u16,
    ) -> Result<Self, RenderError> {
        let path = path.as_ref();
        let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(RenderError::encode(
                path,
                "GIF frames are at most 65535 pixels wide",
            ));
        };
        let file = std::fs::File::create(path).map_err(|e| RenderError::io(path, e))?;
        let mut encoder = gif::Encoder::new(std::io::BufWriter::new(file), w, h, &[])
            .map_err(|e| RenderError::encode(path, e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| RenderError::encode(path, e))?;
        Ok(Self {
            encoder,
            path: path.to_path_buf(),
            width: w,
            height: h,
            delay_cs,
        })
    }

    /// Appends a frame.
    ///
    /// # Errors
    ///
    /// [`RenderError`] when the frame's size is not the one given to [`GifWriter::create`]
    /// or the file cannot be written.
    pub fn add_frame(&mut self, image: &Image) -> Result<(), RenderError> {
        if image.width != self.width as u32 || image.height != self.height as u32 {
            return Err(RenderError::encode(
                &self.path,
                format!(
                    "frame is {}×{}, the GIF is {}×{}",
                    image.width, image.height, self.width, self.height
                ),
            ));
        }
        let mut frame = gif::Frame::from_rgb_speed(self.width, self.height, &image.rgb, 10);
        frame.delay = self.delay_cs;
        self.encoder
            .write_frame(&frame)
            .map_err(|e| RenderError::encode(&self.path, e))
    }

    /// Finishes the file.
    ///
    /// # Errors
    ///
    /// [`RenderError`] when the file cannot be written.
    pub fn finish(self) -> Result<(), RenderError> {
        let path = self.path.clone();
        self.encoder
            .into_inner()
            .map_err(|e| RenderError::encode(&path, e))
            .and_then(|mut w| std::io::Write::flush(&mut w).map_err(|e| RenderError::io(&path, e)))
    }
}
