//! `haptics`: see ARCHITECTURE.md.
