//! The material half of the scene loader: BSDFs, textures and images.

use super::error::SceneError;
use super::loader::Builder;
use super::xml::Properties;
use crate::bsdf::{ConductorFresnel, Material, MaterialKind};
use crate::math::Spectrum;
use crate::texture::{RgbImage, Texture, load_bitmap, load_image};
use glam::{Mat4, Vec2, Vec3};
use roxmltree::Node;
use std::path::Path;
use std::sync::Arc;

impl Builder<'_> {
    pub(super) fn spectrum_or_texture(
        &mut self,
        props: &Properties,
        name: &str,
        default: f32,
    ) -> Result<Texture, SceneError> {
        let ctx = self.ctx;
        let Some(node) = props.rgb_or_texture(name) else {
            return Ok(Texture::Constant(Spectrum::splat(default)));
        };
        let value = match node.tag_name().name() {
            "rgb" => Texture::Constant(ctx.vec3_attr(node, "value")?),
            "float" => Texture::Constant(Spectrum::splat(
                ctx.number(node, ctx.required_attr(node, "value")?)?,
            )),
            "texture" => self.texture(node)?,
            other => {
                return Err(ctx.error(
                    node,
                    format!("property '{name}' must be <rgb>, <float> or <texture>, not <{other}>"),
                ));
            }
        };
        if let Texture::Constant(c) = value
            && c.min_element() < 0.0
        {
            return Err(ctx.error(node, format!("'{name}' must not be negative")));
        }
        Ok(value)
    }

    pub(super) fn texture(&mut self, node: Node) -> Result<Texture, SceneError> {
        let ctx = self.ctx;
        let ty = ctx.required_attr(node, "type")?;
        let props = Properties::new(ctx, node);
        let tex = match ty {
            "bitmap" => {
                let (file, fnode) = props
                    .string("filename")?
                    .ok_or_else(|| ctx.error(node, "bitmap needs a 'filename'"))?;
                let raw = props.boolean("raw", false)?;
                if let Some((f, n)) = props.string("filter_type")?
                    && f != "bilinear"
                {
                    return Err(ctx.error(
                        n,
                        format!("unsupported filter_type '{f}' (only 'bilinear')"),
                    ));
                }
                let path = ctx.resolve_path(fnode, &file)?;
                self.bitmap(&path, raw, fnode)?
            }
            "checkerboard" => {
                let c0 = props.rgb("color0")?.unwrap_or(Spectrum::splat(0.4));
                let c1 = props.rgb("color1")?.unwrap_or(Spectrum::splat(0.2));
                if c0.min_element() < 0.0 || c1.min_element() < 0.0 {
                    return Err(ctx.error(node, "checkerboard colours must not be negative"));
                }
                let scale = match props.transform("to_uv", &["scale", "matrix"])? {
                    None => Vec2::ONE,
                    Some((m, n)) => {
                        // The texture keeps only sx and sy, so any other
                        // entry (z scale included) would be dropped silently.
                        let pure = Mat4::from_scale(Vec3::new(m.x_axis.x, m.y_axis.y, 1.0));
                        let off = (m - pure).to_cols_array();
                        if off.iter().any(|v| v.abs() > 1e-6) {
                            return Err(ctx.error(
                                n,
                                "checkerboard to_uv must be a <scale> (a pure 2D scale)",
                            ));
                        }
                        Vec2::new(m.x_axis.x, m.y_axis.y)
                    }
                };
                Texture::Checkerboard {
                    color0: c0,
                    color1: c1,
                    scale,
                }
            }
            other => return Err(ctx.error(node, format!("unsupported texture type '{other}'"))),
        };
        props.warn_unused();
        ctx.only_properties(node, "a texture", &[])?;
        Ok(tex)
    }

    pub(super) fn image(
        &mut self,
        path: &Path,
        raw: bool,
        node: Node,
    ) -> Result<Arc<RgbImage>, SceneError> {
        let key = (path.to_path_buf(), raw);
        if let Some(img) = self.image_cache.get(&key) {
            return Ok(img.clone());
        }
        self.check_exists(path, node)?;
        let img = load_image(path, raw).map_err(|e| self.ctx.error(node, e))?;
        let img = Arc::new(self.checked(img, path, node)?);
        self.image_cache.insert(key, img.clone());
        Ok(img)
    }

    /// A `bitmap` texture, cached like [`image`](Self::image).
    fn bitmap(&mut self, path: &Path, raw: bool, node: Node) -> Result<Texture, SceneError> {
        let key = (path.to_path_buf(), raw);
        if let Some(t) = self.bitmap_cache.get(&key) {
            return Ok(t.clone());
        }
        self.check_exists(path, node)?;
        let tex = match load_bitmap(path, raw).map_err(|e| self.ctx.error(node, e))? {
            // 8-bit sources decode to finite, non-negative values.
            Texture::Bitmap(img) => {
                let img = Arc::unwrap_or_clone(img);
                Texture::Bitmap(Arc::new(self.checked(img, path, node)?))
            }
            t => t,
        };
        self.bitmap_cache.insert(key, tex.clone());
        Ok(tex)
    }

    fn check_exists(&self, path: &Path, node: Node) -> Result<(), SceneError> {
        if path.exists() {
            Ok(())
        } else {
            Err(self
                .ctx
                .error(node, format!("file not found: '{}'", path.display())))
        }
    }

    /// Rejects float images with non-finite or negative pixels.
    fn checked(&self, img: RgbImage, path: &Path, node: Node) -> Result<RgbImage, SceneError> {
        let bad = img.non_finite_pixels();
        if bad > 0 {
            return Err(self.ctx.error(
                node,
                format!(
                    "image '{}' has {bad} pixels with NaN or Inf",
                    path.display()
                ),
            ));
        }
        if img.pixels.iter().any(|p| p.min_element() < 0.0) {
            return Err(self.ctx.error(
                node,
                format!("image '{}' has negative pixels", path.display()),
            ));
        }
        Ok(img)
    }

    pub(super) fn bsdf(&mut self, node: Node) -> Result<Material, SceneError> {
        let ctx = self.ctx;
        let ty = ctx.required_attr(node, "type")?;
        if ty == "twosided" {
            let inner: Vec<Node> = node.children().filter(|c| c.is_element()).collect();
            if inner.len() != 1 || inner[0].tag_name().name() != "bsdf" {
                return Err(ctx.error(node, "twosided must wrap exactly one inline <bsdf>"));
            }
            let mut m = self.bsdf(inner[0])?;
            if matches!(
                m.kind,
                MaterialKind::Dielectric { .. } | MaterialKind::ThinDielectric { .. }
            ) {
                return Err(ctx.error(inner[0], "twosided cannot wrap a dielectric"));
            }
            if m.two_sided {
                return Err(ctx.error(inner[0], "nested twosided"));
            }
            m.two_sided = true;
            return Ok(m);
        }
        let props = Properties::new(ctx, node);
        let ggx_alpha = |props: &Properties| -> Result<f32, SceneError> {
            if let Some((d, n)) = props.string("distribution")?
                && d != "ggx"
            {
                return Err(ctx.error(
                    n,
                    format!("unsupported microfacet distribution '{d}' (only 'ggx')"),
                ));
            }
            if props.float_opt("alpha_u")?.is_some() {
                return Err(ctx.error(node, "anisotropic roughness is not supported; use 'alpha'"));
            }
            props.float("alpha", 0.1)
        };
        let eta = |props: &Properties, int_default: f32| -> Result<f32, SceneError> {
            let int_ior = props.float("int_ior", int_default)?;
            let ext_ior = props.float("ext_ior", 1.000277)?;
            if !(int_ior > 0.0 && ext_ior > 0.0) {
                return Err(ctx.error(node, "IORs must be positive"));
            }
            Ok(int_ior / ext_ior)
        };
        let conductor = |props: &Properties| -> Result<ConductorFresnel, SceneError> {
            let material = props.string("material")?;
            let eta = props.rgb("eta")?;
            let k = props.rgb("k")?;
            match (material, eta, k) {
                (Some((m, n)), _, _) if m != "none" => Err(ctx.error(
                    n,
                    format!("conductor preset '{m}' is not supported; give 'eta' and 'k' or material 'none'"),
                )),
                (Some(_), None, None) => Ok(ConductorFresnel::None),
                (None, Some(eta), Some(k)) => {
                    if eta.min_element() <= 0.0 || k.min_element() < 0.0 {
                        return Err(ctx.error(node, "conductor 'eta' must be positive and 'k' non-negative"));
                    }
                    Ok(ConductorFresnel::Complex { eta, k })
                }
                (None, None, None) => Ok(ConductorFresnel::None),
                _ => Err(ctx.error(node, "a conductor needs both 'eta' and 'k', or material 'none'")),
            }
        };
        let kind = match ty {
            "diffuse" => MaterialKind::Diffuse {
                reflectance: self.spectrum_or_texture(&props, "reflectance", 0.5)?,
            },
            "roughconductor" => MaterialKind::RoughConductor {
                alpha: ggx_alpha(&props)?,
                fresnel: conductor(&props)?,
                specular_reflectance: self.spectrum_or_texture(
                    &props,
                    "specular_reflectance",
                    1.0,
                )?,
            },
            "conductor" => MaterialKind::Conductor {
                fresnel: conductor(&props)?,
                specular_reflectance: self.spectrum_or_texture(
                    &props,
                    "specular_reflectance",
                    1.0,
                )?,
            },
            "roughplastic" | "plastic" => {
                if props.boolean("nonlinear", false)? {
                    return Err(ctx.error(node, "nonlinear=true is not supported"));
                }
                let diffuse = self.spectrum_or_texture(&props, "diffuse_reflectance", 0.5)?;
                let eta = eta(&props, 1.49)?;
                if ty == "plastic" {
                    MaterialKind::Plastic {
                        eta,
                        diffuse_reflectance: diffuse,
                    }
                } else {
                    MaterialKind::RoughPlastic {
                        alpha: ggx_alpha(&props)?,
                        eta,
                        diffuse_reflectance: diffuse,
                    }
                }
            }
            "dielectric" => MaterialKind::Dielectric {
                eta: eta(&props, 1.5046)?,
            },
            "thindielectric" => MaterialKind::ThinDielectric {
                eta: eta(&props, 1.5046)?,
            },
            other => return Err(ctx.error(node, format!("unsupported bsdf type '{other}'"))),
        };
        props.warn_unused();
        ctx.only_properties(node, "a bsdf", &[])?;
        Material::new(kind, false).map_err(|e| ctx.error(node, e))
    }
}
