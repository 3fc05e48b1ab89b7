"""Figures and tables for people: the paper's figures from the pipeline's results, labelled
axes with units, the paper's figure number in the file name, PNG and PDF twins."""
