//! `raytracer`: see ARCHITECTURE.md.
