//! The renderer's errors, as callers get them.

/// Errors of the renderer; on D-Bus each is `org.hapticd.Renderer1.Error.<Variant>`.
#[derive(Debug, Clone, PartialEq, zbus::DBusError)]
#[zbus(prefix = "org.hapticd.Renderer1.Error")]
pub enum Error {
    /// An option that is not known, or of the wrong type.
    InvalidOption(String),
    /// A number outside its range.
    OutOfRange(String),
    /// A number that is NaN or infinite.
    NotFinite(String),
    /// No Vulkan driver or device on this machine: the service runs without pictures.
    Unavailable(String),
    /// hapticd is not running, or its world cannot be read.
    NoWorld(String),
    /// Drawing failed.
    Failed(String),
    /// A frame of more pixels than `max-frame-pixels`.
    FrameTooLarge(String),
    /// The caller's connection, its user, or everyone together hold as many streams as
    /// they may (`max-streams-per-caller`, `max-streams-per-user`, `max-streams`).
    TooManyStreams(String),
    /// The stream would take its user, or the renderer, past the pixels a second they may
    /// draw (`max-pixel-rate-per-user`, `max-pixel-rate`).
    PixelRateTooHigh(String),
    /// The stream's ring would take the streams past the memory they may hold
    /// (`max-stream-memory`).
    TooMuchMemory(String),
}
