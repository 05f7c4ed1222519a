mod render_groups;
mod techniques;
mod transmission;
