mod api;
mod gpu;
