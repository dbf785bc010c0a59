//! FABRIK (todo)
