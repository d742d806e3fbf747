pub mod directions; pub mod scene;
