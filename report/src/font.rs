//! The one font robosim draws text with: DejaVu Sans, bundled (report/fonts/, licence in
//! report/fonts/LICENSE-DejaVu.txt) so that plots and the display's status line need no system
//! font library (fontconfig, freetype) and look the same everywhere.
//!
//! Entry points: [`SANS_TTF`], [`register_for_plots`].

/// DejaVu Sans 2.37, the whole TrueType file.
pub static SANS_TTF: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// The family name plots ask for (`("sans-serif", size)` in plotters' styles).
pub const PLOT_FAMILY: &str = "sans-serif";

/// Registers [`SANS_TTF`] with plotters as [`PLOT_FAMILY`] (once per process; later calls
/// return the first call's outcome). plotters' `ab_glyph` text has no system fonts: nothing
/// with text can be drawn before this.
pub fn register_for_plots() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        plotters::style::register_font(PLOT_FAMILY, plotters::style::FontStyle::Normal, SANS_TTF)
            .map_err(|_| {
                "the bundled font report/fonts/DejaVuSans.ttf is not a valid TrueType file"
                    .to_owned()
            })
    })
    .clone()
}
