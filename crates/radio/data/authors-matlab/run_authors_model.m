% Runs the authors' own MATLAB model, model80211p.m of msepulcre/IEEE802.11p-model, at every
% configuration of ../published/pdr.csv and writes what it returns to out_csv, one row per
% configuration and distance (0 to 500 m every 25 m): PDR, the four losses and the CBR.
%
% step_db (optional, default the authors' 0.1) is the grid of the model's probability densities
% (step_dB in model80211p.m): another value runs a copy of model80211p.m, in a temporary folder,
% with only that line changed.
%
% GNU Octave 7 with the signal (xcorr) and statistics (normpdf) packages, from the folder of
% this file:
%   octave --no-gui --eval "run_authors_model('/path/to/IEEE802.11p-model', 'model.csv')"
%   octave --no-gui --eval "run_authors_model('/path/to/IEEE802.11p-model', 'model-0.05dB.csv', 0.05)"
function run_authors_model(authors_dir, out_csv, step_db)
  pkg load signal
  pkg load statistics
  % model80211p.m plots its curves; a machine without a display has no graphics toolkit, so the
  % plotting functions it calls are shadowed by functions that do nothing (Octave warns).
  stubs = tempname(); mkdir(stubs);
  for name = {'figure', 'hold', 'plot', 'title', 'ylim', 'xlabel', 'ylabel', 'legend', 'stem'}
    f = fopen(fullfile(stubs, [name{1} '.m']), 'w');
    fprintf(f, 'function h = %s(varargin)\n  h = 1;\nend\n', name{1});
    fclose(f);
  end
  if nargin > 2 && step_db ~= 0.1
    text = fileread(fullfile(authors_dir, 'model80211p.m'));
    line = 'step_dB = 0.1;';
    if numel(strfind(text, line)) ~= 1
      error('model80211p.m: expected one line "%s"', line);
    end
    text = strrep(text, line, sprintf('step_dB = %g;', step_db));
    f = fopen(fullfile(stubs, 'model80211p.m'), 'w');
    fputs(f, text);
    fclose(f);
  end
  addpath(authors_dir);
  addpath(stubs);  % ahead of authors_dir
  here = fileparts(mfilename('fullpath'));
  table = dlmread(fullfile(here, '..', 'published', 'pdr.csv'), ',', 1, 0);
  keys = unique(table(:, 1:5), 'rows', 'stable');
  out = fopen(out_csv, 'w');
  fprintf(out, 'density_veh_per_m,data_rate_mbps,beacon_hz,tx_power_dbm,packet_bytes,distance_m,pdr,sen,rxb,pro,col,cbr\n');
  for k = 1:size(keys, 1)
    beta = keys(k, 1); rate = keys(k, 2); lambda = keys(k, 3); pt = keys(k, 4); bytes = keys(k, 5);
    [pdr, sen, rxb, pro, col, cbr] = model80211p(beta, lambda, pt, bytes, rate * 1e6);
    d = 0:25:500;
    for i = 1:numel(d)
      fprintf(out, '%g,%g,%g,%g,%g,%g,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f\n', beta, rate, lambda, pt, bytes, d(i), pdr(i), sen(i), rxb(i), pro(i), col(i), cbr);
    end
  end
  fclose(out);
end
