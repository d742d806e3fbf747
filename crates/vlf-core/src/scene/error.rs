//! Errors of the scene importer.

use std::path::PathBuf;

/// A fatal problem while importing a scene. Every message names the offending
/// element where there is one and ends with the path of the scene file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene file itself cannot be read (missing, a directory, no permission…).
    #[error("cannot read scene file ({cause}): {path}")]
    Io {
        /// Scene file.
        path: PathBuf,
        /// Underlying I/O error (in the message, not chained: the message already names it).
        cause: std::io::Error,
    },

    /// The binary glTF container is malformed.
    #[error("invalid GLB container: {reason}: {path}")]
    Glb {
        /// What is wrong.
        reason: String,
        /// Scene file.
        path: PathBuf,
    },

    /// The JSON is malformed or does not follow the glTF schema.
    #[error("invalid glTF JSON: {message}: {path}")]
    Json {
        /// The serde_json message (with line and column).
        message: String,
        /// Scene file.
        path: PathBuf,
    },

    /// `extensionsRequired` lists an extension the importer does not implement.
    #[error("unsupported required extension {extension}: {path}")]
    UnsupportedExtension {
        /// Extension name.
        extension: String,
        /// Scene file.
        path: PathBuf,
    },

    /// An external or embedded resource (buffer or image) cannot be read or decoded.
    #[error("{element}: cannot read {file} ({reason}): {path}")]
    Resource {
        /// E.g. `buffer 0` or `image 2 ("wall")`.
        element: String,
        /// The resolved file name, or `embedded data` / `GLB binary chunk`.
        file: String,
        /// What went wrong.
        reason: String,
        /// Scene file.
        path: PathBuf,
    },

    /// A structural problem with one element (bad index, byte range, type, …).
    #[error("{element}: {reason}: {path}")]
    Invalid {
        /// E.g. `mesh 3 primitive 0`, `accessor 7`, `node 2`.
        element: String,
        /// What is wrong.
        reason: String,
        /// Scene file.
        path: PathBuf,
    },

    /// A vertex index points past the end of the primitive's vertex attributes.
    #[error(
        "{element}: vertex index {index} is out of range (the primitive has {vertex_count} vertices): {path}"
    )]
    IndexOutOfRange {
        /// E.g. `mesh 3 primitive 0`.
        element: String,
        /// The offending index value.
        index: u64,
        /// Number of vertices of the primitive.
        vertex_count: usize,
        /// Scene file.
        path: PathBuf,
    },

    /// A vertex position is NaN or infinite (in the file or after the node transform).
    #[error("{element}: non-finite vertex position {value} at vertex {vertex}: {path}")]
    NonFinitePosition {
        /// E.g. `mesh 3 primitive 0 (node 5)`.
        element: String,
        /// Vertex number in the primitive.
        vertex: usize,
        /// The position as read/transformed.
        value: String,
        /// Scene file.
        path: PathBuf,
    },

    /// No triangle is left after import.
    #[error("empty scene: no triangles left after import ({detail}): {path}")]
    Empty {
        /// Why (what was skipped).
        detail: String,
        /// Scene file.
        path: PathBuf,
    },

    /// More than [`super::MAX_TRIANGLES`] triangles.
    #[error("scene too large: more than {limit} triangles after instancing: {path}")]
    TooLarge {
        /// The limit.
        limit: usize,
        /// Scene file.
        path: PathBuf,
    },

    /// [`super::check_lighting`]: nothing emits light.
    #[error("no emitters, no lights and no sky: nothing would be lit (in {path})")]
    NothingLit {
        /// Scene file.
        path: PathBuf,
    },
}
