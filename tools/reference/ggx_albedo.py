#!/usr/bin/env python3
"""Reference directional albedo of the GGX microfacet BRDF (Fresnel = 1,
Smith height-correlated G2), by deterministic quadrature, independent of the
C++ code. Prints the table embedded in core/render/bsdf_test.cc.

E(mu, alpha) = integral over the hemisphere of f(wo, wi) cos(theta_i) dwi.
Substituting the half vector h with tan^2(theta_h) = alpha^2 u / (1 - u)
(GGX's inverse CDF) makes D(h) cos(theta_h) dwh = du dphi / (2 pi), so
E = (1/2pi) int int G2(wo, wi) (wo.h) / (mu cos(theta_h)) du dphi
with wi = reflect(wo, h), counted only where wi is above the surface.
"""
import math


def lam(cos_t, alpha):
    cos2 = cos_t * cos_t
    if cos2 >= 1.0:
        return 0.0
    tan2 = (1.0 - cos2) / cos2
    return 0.5 * (-1.0 + math.sqrt(1.0 + alpha * alpha * tan2))


def albedo(mu, alpha, n_u=1500, n_phi=480):
    wo = (math.sqrt(1.0 - mu * mu), 0.0, mu)
    lam_o = lam(mu, alpha)
    total = 0.0
    for i in range(n_u):
        u = (i + 0.5) / n_u
        tan_t = alpha * math.sqrt(u / (1.0 - u))
        cos_h = 1.0 / math.sqrt(1.0 + tan_t * tan_t)
        sin_h = tan_t * cos_h
        row = 0.0
        for j in range(n_phi):
            phi = 2.0 * math.pi * (j + 0.5) / n_phi
            h = (sin_h * math.cos(phi), sin_h * math.sin(phi), cos_h)
            o_h = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2]
            if o_h <= 0.0:
                continue
            wi_z = 2.0 * o_h * h[2] - wo[2]
            if wi_z <= 0.0:
                continue
            g2 = 1.0 / (1.0 + lam_o + lam(wi_z, alpha))
            row += g2 * o_h / (mu * cos_h)
        total += row / n_phi
    return total / n_u


if __name__ == "__main__":
    for alpha in (0.02, 0.05, 0.13, 0.34, 0.7, 1.0):
        values = [albedo(mu, alpha) for mu in (0.2, 0.5, 0.8, 1.0)]
        print("    {%.2f, {%s}}," % (alpha, ", ".join("%.5f" % v for v in values)))
