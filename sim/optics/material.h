// Optical materials: complex refractive index n(λ) + i k(λ), λ in nanometres, k >= 0.
//
// Parameter table (defaults are the published values collected in DESIGN.md):
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

std::shared_ptr<const Material> keratin();
std::shared_ptr<const Material> melanin();
std::shared_ptr<const Material> air();

}  // namespace plumage::optics
