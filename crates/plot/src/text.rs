//! Text for the figures, laid out glyph by glyph *with* each glyph's side bearing.
//!
//! plotters 0.3.7 draws `ab_glyph` text by placing each glyph's ink box at the pen position,
//! dropping the glyph's left side bearing, so letters drift apart or collide ("baselin e").
//! [`GlyphText`] wraps any plotters backend and draws text itself: the pen advances by each
//! glyph's advance plus kerning, and the ink goes where the font puts it. Everything else is
//! the wrapped backend's.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use plotters_backend::{
    text_anchor::{HPos, VPos},
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// The figures' font (the same bytes plotters is given, so sizes match).
pub(super) fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).ok()
}

/// A plotters backend whose text is laid out with side bearings and kerning.
pub(super) struct GlyphText<B> {
    inner: B,
    font: FontRef<'static>,
}

impl<B> GlyphText<B> {
    /// Wraps `inner`, drawing text in `font`.
    pub(super) fn new(inner: B, font: FontRef<'static>) -> Self {
        GlyphText { inner, font }
    }
}

/// A pixel of ink: its position relative to the pen's start on the baseline, and coverage.
type Ink = (i32, i32, f32);

/// Lays `text` out at `size` px: the ink of every glyph, and the box (width, height) the
/// anchor aligns — from the pen's start to its end, from the ascender to the descender.
pub(super) fn layout(font: &FontRef<'_>, size: f64, text: &str) -> (Vec<Ink>, (i32, i32)) {
    let scaled = font.as_scaled(PxScale::from(size as f32));
    let ascent = scaled.ascent();
    let mut ink = Vec::new();
    let mut pen = 0.0f32;
    let mut prev = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            pen += scaled.kern(p, id);
        }
        prev = Some(id);
        let glyph = id.with_scale_and_position(scaled.scale(), point(pen, ascent));
        if let Some(outline) = scaled.outline_glyph(glyph) {
            let b = outline.px_bounds();
            outline.draw(|x, y, coverage| {
                ink.push((
                    b.min.x as i32 + x as i32,
                    b.min.y as i32 + y as i32,
                    coverage,
                ));
            });
        }
        pen += scaled.h_advance(id);
    }
    let height = (ascent - scaled.descent()).ceil() as i32;
    (ink, (pen.ceil() as i32, height))
}

impl<B: DrawingBackend> DrawingBackend for GlyphText<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (_, (w, h)) = layout(&self.font, style.size(), text);
        Ok((w.max(0) as u32, h.max(0) as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let (ink, (width, height)) = layout(&self.font, style.size(), text);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let transform = style.transform();
        let (w, h) = self.get_size();
        for (x, y, coverage) in ink {
            let (x, y) = transform.transform(x + dx, y + dy);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                let alpha = color.alpha * f64::from(coverage.clamp(0.0, 1.0));
                self.inner
                    .draw_pixel((x, y), BackendColor { alpha, ..color })?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The columns holding ink, per glyph of a two-letter text.
    fn ink_columns(text: &str) -> Vec<i32> {
        let f = font().unwrap();
        let (ink, _) = layout(&f, 80.0, text);
        let mut cols: Vec<i32> = ink.iter().filter(|i| i.2 > 0.0).map(|i| i.0).collect();
        cols.sort_unstable();
        cols.dedup();
        cols
    }

    #[test]
    fn glyphs_sit_at_their_side_bearings() {
        let f = font().unwrap();
        let s = f.as_scaled(PxScale::from(80.0));
        let (n, e) = (s.glyph_id('n'), s.glyph_id('e'));
        let e_box = s
            .outline_glyph(e.with_scale(s.scale()))
            .unwrap()
            .px_bounds();
        // The font gives `e` a left bearing of several pixels at this size: dropping it (as
        // plotters does) would move the `e` that far to the left.
        assert!(e_box.min.x >= 3.0, "{e_box:?}");
        // The ink of `e` starts at the pen (after `n` and kerning) plus e's own left bearing.
        let expected = s.h_advance(n) + s.kern(n, e) + e_box.min.x;
        let cols = ink_columns("ne");
        let gap_end = cols.windows(2).find(|w| w[1] - w[0] > 1).unwrap()[1];
        assert!(
            (gap_end as f32 - expected).abs() <= 1.0,
            "the e starts at {gap_end} px, the font says {expected:.1}"
        );
        // The first glyph starts at its own left bearing, not at the pen.
        let n_box = s
            .outline_glyph(n.with_scale(s.scale()))
            .unwrap()
            .px_bounds();
        assert_eq!(cols[0], n_box.min.x as i32);
    }

    #[test]
    fn the_layout_box_is_the_advance_and_line_height() {
        let f = font().unwrap();
        let s = f.as_scaled(PxScale::from(14.0));
        let (_, (w, h)) = layout(&f, 14.0, "ab");
        let advance = s.h_advance(s.glyph_id('a'))
            + s.kern(s.glyph_id('a'), s.glyph_id('b'))
            + s.h_advance(s.glyph_id('b'));
        assert_eq!(w, advance.ceil() as i32);
        assert_eq!(h, (s.ascent() - s.descent()).ceil() as i32);
    }
}
