// Optical materials: complex refractive index n(λ) + i k(λ), λ in nanometres, k >= 0.
//
// Parameter table (defaults: the published values whose sources the range table below names):
//
//  | material | model                                  | parameters                     |
//  |----------|----------------------------------------|--------------------------------|
//  | keratin  | n = A + B/λ²                           | A = 1.532, B = 5890 nm²        |
//  | melanin  | n = A + B/λ², k = C exp(−λ/D)          | A = 1.648, B = 23700 nm²,      |
//  |          |                                        | C = 0.56, D = 270 nm           |
//  | air      | n = 1                                  |                                |
//
// Valid ranges: A > 0, B >= 0, C >= 0, D > 0; n(λ) must stay positive. Tabulated
// materials interpolate linearly and reject wavelengths outside their table.
//
// Spectral range of keratin() and melanin(): kDispersionMinNm–kDispersionMaxNm (300–800 nm),
// one formula across it (so n, k and their derivatives are continuous at every join), each
// sub-range with its source and how far it can be trusted:
//
//  | range (nm) | keratin                                 | melanin                               |
//  |------------|-----------------------------------------|---------------------------------------|
//  | 400–700    | measured: Leertouwer, Wilts & Stavenga  | measured: Stavenga, Leertouwer, Osorio|
//  |            | 2011, Opt. Express 19:24061 (Jamin-     | & Wilts 2015, Light Sci. Appl. 4:e243 |
//  |            | Lebedeff, goose barbules; 1.569, 1.556, | (Jamin-Lebedeff, Parotia barbules,    |
//  |            | 1.548 at 400, 500, 600 nm)              | n 1.7–1.8, k from absorbance)         |
//  | 700–800    | Cauchy extrapolated 100 nm: no          | Cauchy and exponential k extrapolated:|
//  |            | absorption band nearby, the B/λ² term   | n changes by 0.011 from 700 to 800 nm,|
//  |            | changes n by 0.0028 over the range; off | k by 0.013; off by ≲ 0.01 in n, k    |
//  |            | by ≲ 0.002                              | (melanin's absorption is monotone)    |
//  | 300–400    | Cauchy extrapolated 100 nm: n(300) =    | extrapolated: n(300) = 1.911,         |
//  |            | 1.597. Keratin absorbs below ~300 nm    | k(300) = 0.18. Melanin absorbs ever   |
//  |            | (aromatic residues, peak ~280 nm), and  | more strongly into the UV (k rises    |
//  |            | near-UV anomalous dispersion of feather | monotonically, as the formula does),  |
//  |            | keratin was reported by Brink & van der | but no measurement of n below 400 nm  |
//  |            | Berg 2004, J. Phys. D 37:813; so the    | was found: n may be off by ~0.05.     |
//  |            | true n near 300 nm is likely higher, by |                                       |
//  |            | an estimated ≲ 0.03, and k > 0 (not     |                                       |
//  |            | modelled)                               |                                       |
//
// Study files refuse wavelengths outside this range (studies/sections.h, WavelengthRule);
// index() itself accepts any positive wavelength (the formulas are defined there).
#pragma once

#include <complex>
#include <memory>
#include <string>
#include <vector>

namespace plumage::optics {

class Material {
public:
    virtual ~Material() = default;
    // Complex index at a vacuum wavelength; throws InputError outside the valid range.
    virtual std::complex<double> index(double lambda_nm) const = 0;
    virtual const std::string& name() const = 0;
};

// n = A + B/λ², k = C exp(−λ/D) (C = 0: lossless). Keratin and melanin are instances.
class CauchyMaterial final : public Material {
public:
    CauchyMaterial(std::string name, double a, double b_nm2, double k_amplitude = 0.0,
                   double k_decay_nm = 1.0);
    std::complex<double> index(double lambda_nm) const override;
    const std::string& name() const override { return name_; }

private:
    std::string name_;
    double a_, b_nm2_, k_amplitude_, k_decay_nm_;
};

class ConstantMaterial final : public Material {
public:
    ConstantMaterial(std::string name, std::complex<double> n);
    std::complex<double> index(double lambda_nm) const override;
    const std::string& name() const override { return name_; }

private:
    std::string name_;
    std::complex<double> n_;
};

class TabulatedMaterial final : public Material {
public:
    // Strictly increasing wavelengths; n > 0 and k >= 0 at every entry.
    TabulatedMaterial(std::string name, std::vector<double> lambda_nm, std::vector<double> n,
                      std::vector<double> k);
    std::complex<double> index(double lambda_nm) const override;
    const std::string& name() const override { return name_; }

private:
    std::string name_;
    std::vector<double> lambda_nm_, n_, k_;
};

inline constexpr double kDispersionMinNm = 300.0;
inline constexpr double kDispersionMaxNm = 800.0;

std::shared_ptr<const Material> keratin();
std::shared_ptr<const Material> melanin();
std::shared_ptr<const Material> air();

}  // namespace plumage::optics
