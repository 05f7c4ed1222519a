mod gpu;
mod twin;
