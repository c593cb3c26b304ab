//! Command-line arguments every tool that imports a model takes (`cooker cook`, `init`,
//! `validate`, the viewer), so each reads, documents and applies them the same way.

use crate::Settings;
use crate::import::text::TextEncoding;
use crate::settings::UpAxis;

/// How a model's files are read: its up axis and the encoding of its names.
#[derive(clap::Args, Clone, Debug)]
pub struct ModelArgs {
    /// The up axis of a bare model: `z` stands up a Z-up model (SketchUp, Revit, 3ds Max
    /// exports) as the pipeline, Y-up like glTF, needs it. A scene.toml turns its meshes with
    /// `rotate_deg` instead (`cooker init --up z` writes it).
    #[arg(long, value_name = "y|z", default_value = "y", value_parser = UpAxis::from_arg)]
    pub up: UpAxis,
    /// How names in OBJ and MTL files that are not UTF-8 are read: a WHATWG label such as
    /// `windows-1251`, `windows-1250`, `shift_jis` or `gbk`. Without it the encoding is
    /// guessed from the names (or taken from the manifest's `text_encoding`), and the cook says
    /// which it took.
    #[arg(long, value_name = "LABEL", value_parser = TextEncoding::from_label)]
    pub text_encoding: Option<TextEncoding>,
}

impl ModelArgs {
    /// Onto settings made from a manifest: the up axis, and the encoding where one is given
    /// (else the manifest's stays).
    pub fn apply(&self, settings: &mut Settings) {
        settings.up = self.up;
        if self.text_encoding.is_some() {
            settings.text_encoding = self.text_encoding;
        }
    }
}

/// Makes a failed write to stdout or stderr (`> /dev/full`, a full disk behind a redirect) end
/// the process with [`crate::EXIT_IO`] and one line saying so, where `println!` and
/// `eprintln!` panic with a backtrace. The tools print with those macros throughout; whatever
/// file they wrote before (a pack, a PNG) is already whole, renamed into place.
pub fn exit_on_failed_output() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.starts_with("failed printing to std") {
            use std::io::Write;
            // stderr may be the stream that failed: nothing more to do about it then.
            let _ = writeln!(std::io::stderr(), "error: {message}");
            std::process::exit(crate::EXIT_IO);
        }
        default(info);
    }));
}
