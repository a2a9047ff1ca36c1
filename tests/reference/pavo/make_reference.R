# Makes the pavo reference of tests/analysis/avian_pavo_test.cpp: quantum catches and colour
# distances that pavo 2.9.0 computes for its own birds (bluetit, pfowl, avg.uv, avg.v) from
# spectra exported by plumage, and the tables of pavo's data the project uses (sensitivities,
# double cones, D65). Not run in CI; README.md beside this file says how to run it.
#
#   Rscript make_reference.R PAVO_SOURCE_DIR SPECTRA_CSV OUT_DIR DATA_CSV
#
# PAVO_SOURCE_DIR: an unpacked pavo 2.9.0 source tree (its R/ folder and R/sysdata.rda are
# loaded; pavo itself is not installed). SPECTRA_CSV: spectra in pavo's layout (wl in nm, one
# column per sample, reflectance in per cent), as plumage writes them (spectra_pavo.csv), on a
# grid within 300-700 nm, where pavo's sensitivities are defined. Spanning all of it, they go
# through pavo's built-in birds; spanning less (400-700 nm, say), through the same birds' data
# cut to the grid's span as user-defined systems, so no reflectance is invented either way.
# OUT_DIR receives catches.csv, distances.csv and a copy of the spectra; DATA_CSV pavo's tables
# (analysis/metrics/data/pavo_visual_systems.csv), or "-" for none.

args <- commandArgs(trailingOnly = TRUE)
if (length(args) != 4) {
  stop("usage: Rscript make_reference.R PAVO_SOURCE_DIR SPECTRA_CSV OUT_DIR DATA_CSV")
}
pavo_dir <- args[1]
spectra_csv <- args[2]
out_dir <- args[3]
data_csv <- args[4]

description <- read.dcf(file.path(pavo_dir, "DESCRIPTION"))
if (description[1, "Version"] != "2.9.0") {
  stop("expected pavo 2.9.0 in ", pavo_dir, ", found ", description[1, "Version"])
}

# pavo's functions and internal data, loaded into one environment.
pavo <- new.env()
for (f in list.files(file.path(pavo_dir, "R"), pattern = "[.]R$", full.names = TRUE)) {
  sys.source(f, envir = pavo)
}
load(file.path(pavo_dir, "R", "sysdata.rda"), envir = pavo)

# The four birds: pavo's name, the double cone for the achromatic channel and the relative cone
# densities (UV/V : S : M : L; sources in analysis/metrics/data/README.md).
birds <- data.frame(
  visual = c("bluetit", "avg.uv", "avg.v", "pfowl"),
  achromatic = c("bt.dc", "bt.dc", "ch.dc", "ch.dc"),
  n = c("1:2:2:4", "1:2:2:4", "1:2:2:4", "1:1.9:2.2:2.1"),
  stringsAsFactors = FALSE
)
weber <- 0.1
weber_achro <- 0.1

spectra <- with(pavo, as.rspec(read.csv(spectra_csv, check.names = FALSE)))
if (min(spectra$wl) < 300 || max(spectra$wl) > 700) {
  stop(spectra_csv, " covers ", min(spectra$wl), "-", max(spectra$wl),
       " nm after as.rspec; pavo's birds are defined on 300-700 nm only")
}
span <- pavo$vissyst$wl >= min(spectra$wl) & pavo$vissyst$wl <= max(spectra$wl)
full_range <- all(span)
if (max(spectra[, -1]) <= 1) {
  stop(spectra_csv, ": no value above 1; vismodel would take the per-cent values as fractions")
}

catches <- list()
distances <- list()
for (b in seq_len(nrow(birds))) {
  bird <- birds[b, ]
  n <- as.numeric(strsplit(bird$n, ":")[[1]])
  if (full_range) {
    vm <- pavo$vismodel(spectra, visual = bird$visual, achromatic = bird$achromatic,
                        illum = "D65", vonkries = TRUE, relative = FALSE)
  } else {
    cones <- pavo$vissyst[span, c("wl", paste0(bird$visual, ".", c("u", "s", "m", "l")))]
    vm <- pavo$vismodel(spectra, visual = cones, achromatic = pavo$vissyst[span, bird$achromatic],
                        illum = pavo$bgandilum$D65[span], vonkries = TRUE, relative = FALSE)
  }
  # The double cone's catch is not von Kries-adapted in vismodel; its white-light catch over
  # the same span, for the adapted value lum / lum_white.
  lum_white <- sum(pavo$vissyst[span, bird$achromatic] * pavo$bgandilum$D65[span])
  catches[[b]] <- data.frame(
    visual = bird$visual, achromatic = bird$achromatic,
    first_nm = min(spectra$wl), last_nm = max(spectra$wl), spectrum = rownames(vm),
    q1 = vm[, 1], q2 = vm[, 2], q3 = vm[, 3], q4 = vm[, 4],
    lum = vm$lum, lum_white = lum_white, stringsAsFactors = FALSE
  )
  cd <- pavo$coldist(vm, noise = "neural", achromatic = TRUE, n = n, weber = weber,
                     weber.ref = "longest", weber.achro = weber_achro)
  distances[[b]] <- data.frame(
    visual = bird$visual, achromatic = bird$achromatic, densities = bird$n,
    weber = weber, weber_achro = weber_achro,
    patch1 = cd$patch1, patch2 = cd$patch2, dS = cd$dS, dL = cd$dL,
    stringsAsFactors = FALSE
  )
}

dir.create(out_dir, showWarnings = FALSE, recursive = TRUE)
write.csv(do.call(rbind, catches), file.path(out_dir, "catches.csv"), row.names = FALSE)
write.csv(do.call(rbind, distances), file.path(out_dir, "distances.csv"), row.names = FALSE)
copy_to <- file.path(out_dir, "spectra_pavo.csv")
if (!file.exists(copy_to) || normalizePath(spectra_csv) != normalizePath(copy_to)) {
  file.copy(spectra_csv, copy_to, overwrite = TRUE)
}

# pavo's data as the project keeps it: one row per nm, 300-700.
columns <- c(paste0(rep(birds$visual, each = 4), ".", c("u", "s", "m", "l")),
             "bt.dc", "ch.dc")
data <- cbind(pavo$vissyst[, c("wl", columns)], D65 = pavo$bgandilum$D65)
if (data_csv == "-") quit(save = "no")
con <- file(data_csv, "w")
writeLines(c(
  "# pavo 2.9.0's internal data (R/sysdata.rda: vissyst, bgandilum$D65), 1 nm, 300-700 nm,",
  "# as tests/reference/pavo/make_reference.R writes it; sources per column: analysis/metrics/data/README.md."
), con)
write.csv(data, con, row.names = FALSE)
close(con)
