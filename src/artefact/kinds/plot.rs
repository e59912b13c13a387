//! The `plot` kind: one figure as `<name>.png` and `<name>.svg`, its title in the metadata.

use super::{Kind, Layout, expect_kind, meta};
use crate::artefact::{Artefact, ArtefactError, ArtefactKind};

/// A figure as stored: its file stem, title and both renderings.
#[derive(Clone, Debug, PartialEq)]
pub struct Plot {
    /// File stem of both blobs.
    pub name: String,
    /// Title.
    pub title: String,
    /// PNG bytes.
    pub png: Vec<u8>,
    /// SVG text.
    pub svg: String,
}

/// The `plot` kind.
pub struct PlotKind;

impl Kind for PlotKind {
    const KIND: ArtefactKind = ArtefactKind::Plot;
    const NAME: &'static str = "plot";
    type Value = Plot;

    fn layout() -> Layout {
        Layout {
            tables: vec![],
            meta: vec![meta("title", "figure title")],
            blobs: vec!["{name}.png", "{name}.svg"],
        }
    }

    fn to_artefact(p: &Plot) -> Artefact {
        let mut a = Artefact::new(Self::KIND).with_meta("title", p.title.as_str().into());
        a.blobs.insert(format!("{}.png", p.name), p.png.clone());
        a.blobs
            .insert(format!("{}.svg", p.name), p.svg.clone().into_bytes());
        a
    }

    fn from_artefact(a: &Artefact) -> Result<Plot, ArtefactError> {
        expect_kind(a, Self::KIND)?;
        let bad = |m: String| ArtefactError::schema(Self::KIND, m);
        let Some((file, png)) = a.blobs.iter().find(|(n, _)| n.ends_with(".png")) else {
            return Err(bad("no `.png` blob".into()));
        };
        let name = file.trim_end_matches(".png").to_string();
        let svg = a
            .blobs
            .get(&format!("{name}.svg"))
            .ok_or_else(|| bad(format!("no `{name}.svg` beside `{file}`")))?;
        Ok(Plot {
            title: a.meta_str("title")?.to_string(),
            png: png.clone(),
            svg: String::from_utf8(svg.clone()).map_err(|e| bad(format!("`{name}.svg`: {e}")))?,
            name,
        })
    }
}

/// A plot artefact holding `<name>.png` and `<name>.svg`.
pub fn plot_artefact(name: &str, title: &str, fig: crate::report::frf_plot::Figure) -> Artefact {
    let mut a = Artefact::new(PlotKind::KIND).with_meta("title", title.into());
    a.blobs.insert(format!("{name}.png"), fig.png);
    a.blobs.insert(format!("{name}.svg"), fig.svg.into_bytes());
    a
}
