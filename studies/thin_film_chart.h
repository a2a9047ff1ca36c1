// The thin-film study (Huang et al. 2022, Figs. 3 and 5): the reflected colour of a
// keratin film in air against thickness and incidence angle under D65, and the
// normal-incidence reflectance spectra of the rock dove's 530 nm (purple, lower neck)
// and 595 nm (green, upper neck) films, with and without the melanin background (TRT).
//
// Physics: Airy film (sim/optics/thin_film.h), unpolarised; keratin and melanin
// dispersion from sim/optics/material.h. TRT at normal incidence is Huang's Eq. 3:
// I_TRT = |t|² |r_am|² |t'|², transmission through the film, Fresnel reflection at
// air–melanin, transmission back; it adds to I_R by intensity (no interference).
#pragma once

#include <filesystem>
#include <vector>

#include "sim/optics/colour.h"

namespace plumage::studies {

struct ThinFilmChartOptions {
    std::filesystem::path output_dir = "results/thin_film";
    double max_thickness_nm = 1000.0;
    double thickness_step_nm = 2.0;
    double angle_step_deg = 1.0;
    double chart_wavelength_step_nm = 5.0;  // chart: 380–780 nm
    double spectra_wavelength_step_nm = 1.0;
    bool plots = true;     // matplotlib figures (needs /usr/bin/python3)
    bool progress = true;  // progress lines on stderr
};

struct FilmColour {
    double thickness_nm;
    bool with_melanin_background;  // R + TRT rather than R alone
    optics::Xyz xyz;
    optics::Lab lab;
    double hue_deg;
    double chroma;
    // ΔE00 between the colour from the chart's wavelength grid and from the 1 nm
    // spectra grid: the colour quadrature error of the chart.
    double delta_e00_chart_grid;
};

struct ThinFilmChartResult {
    std::filesystem::path output_dir;
    std::vector<FilmColour> normal_incidence;  // 530 and 595 nm, without and with TRT
    double exposure;                           // display scale applied before sRGB encoding
    double wall_seconds;
};

// Writes into options.output_dir (replaced atomically): thin_film_chart.h5,
// thin_film_chart_pixels.png, spectra_normal_incidence.csv, report.md and, with plots,
// thin_film_chart.png and spectra_normal_incidence.png.
ThinFilmChartResult run_thin_film_chart(const ThinFilmChartOptions& options);

}  // namespace plumage::studies
